#include "support/run_compare.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "scene/scene_json.h"

namespace millsim::test {

using nlohmann::json;

SceneConfig shipped_case(const std::string& file, double end_s,
                         const std::function<void(json&)>& edit) {
  std::ifstream in(std::string(MILLSIM_SOURCE_DIR "/cases/") + file);
  json doc = json::parse(in);
  doc["time"]["end_s"] = end_s;
  if (edit) edit(doc);
  InputErrors errors;
  SceneConfig scene = parse_scene(doc, MILLSIM_SOURCE_DIR "/cases", errors);
  EXPECT_TRUE(errors.empty()) << file;
  return scene;
}

// Every per-particle column, the tallies and the gas fields, compared byte for byte.
void expect_identical(Simulation& a, Simulation& b) {
  ASSERT_EQ(a.step_index(), b.step_index());
  ASSERT_EQ(a.particles().size(), b.particles().size());
  int column = 0;
  std::vector<std::string> a_bytes, b_bytes;
  a.particles().for_each_column([&](auto& c) {
    a_bytes.emplace_back(reinterpret_cast<const char*>(c.data()), c.size() * sizeof c[0]);
  });
  b.particles().for_each_column([&](auto& c) {
    b_bytes.emplace_back(reinterpret_cast<const char*>(c.data()), c.size() * sizeof c[0]);
  });
  ASSERT_EQ(a_bytes.size(), b_bytes.size());
  for (; column < int(a_bytes.size()); ++column)
    EXPECT_TRUE(a_bytes[std::size_t(column)] == b_bytes[std::size_t(column)])
        << "particle column " << column << " differs";
  EXPECT_TRUE(same_bytes(a.outlet_tally().mass_kg, b.outlet_tally().mass_kg));
  EXPECT_EQ(a.energy().total_j(), b.energy().total_j());
  EXPECT_EQ(a.mass_balance().fed_kg, b.mass_balance().fed_kg);
  EXPECT_EQ(a.neighbors().stats().rebuilds, b.neighbors().stats().rebuilds);
  if (a.breakage()) {
    EXPECT_EQ(a.breakage()->stats().events, b.breakage()->stats().events);
    EXPECT_TRUE(same_bytes(a.breakage()->dust().mass_kg, b.breakage()->dust().mass_kg));
  }
  if (a.dust_ledger()) {
    const DustLedger &da = *a.dust_ledger(), &db = *b.dust_ledger();
    for (int k = 0; k < da.class_count(); ++k) {
      EXPECT_TRUE(same_bytes(da.cell_mass_kg(k), db.cell_mass_kg(k))) << "dust class " << k;
      EXPECT_EQ(da.outflow_kg(k), db.outflow_kg(k)) << "dust class " << k;
    }
  }
  if (a.dust_grinding()) {
    ASSERT_NE(b.dust_grinding(), nullptr);
    EXPECT_TRUE(
        same_bytes(a.dust_grinding()->stats().ground_kg, b.dust_grinding()->stats().ground_kg));
  }
  if (a.gas() && a.gas()->compressible()) {
    const CompressibleSolver &ga = *a.gas()->compressible(), &gb = *b.gas()->compressible();
    std::vector<double> state_a, state_b;  // density, velocity and pressure of every cell
    for (std::size_t c = 0; c < ga.grid().padded_size; ++c) {
      if (!ga.grid().fluid[c]) continue;
      for (const CompressibleSolver* g : {&ga, &gb}) {
        std::vector<double>& out = g == &ga ? state_a : state_b;
        const Vec3 u = g->velocity_m_per_s(c);
        out.insert(out.end(), {g->density_kg_per_m3(c), u.x, u.y, u.z, g->pressure_pa(c)});
      }
    }
    EXPECT_TRUE(same_bytes(state_a, state_b));
    EXPECT_EQ(a.gas()->stats().cfd_steps, b.gas()->stats().cfd_steps);
  } else if (a.gas()) {
    EXPECT_TRUE(same_bytes(a.gas()->gas().pressure(), b.gas()->gas().pressure()));
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_TRUE(same_bytes(a.gas()->gas().velocity()[std::size_t(axis)],
                             b.gas()->gas().velocity()[std::size_t(axis)]));
    EXPECT_EQ(a.gas()->stats().cfd_steps, b.gas()->stats().cfd_steps);
    EXPECT_EQ(a.gas()->stats().drag_reuses, b.gas()->stats().drag_reuses);
  }
}

}  // namespace millsim::test
