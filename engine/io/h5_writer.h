// run.h5 writer: particle snapshots and time series, plus the XDMF index that lets ParaView
// open the snapshots as a time series of point clouds. The only file that includes HDF5.
//
// Layout:  /snapshots/sNNNNNNNNN/{position, velocity, angular_velocity (N×3), diameter (N),
//                                  id (N, uint64), material (N, int32)}, attributes step, time_s
//          + with gas: gas_velocity (nz×ny×nx×3), gas_pressure, gas_volume_fraction,
//            gas_fluid (nz×ny×nx, cell centres; 1 = fluid cell, 0 = solid)
//          /geometry/{points (P×3), triangles (T×3), part (T)}, attribute "parts" (the part
//                     names, one per line): walls, outlets, gas patches and jets
//          /timeseries/<column> (one 1-D dataset per column; "time_s" first)
//          /psd/<column> (outlet PSD, when the scene has outlets or breakage: edges_m, outlet and
//                         dust count and mass per class, product cumulative mass)
//          /meta attributes: the scene as given, its seed, the build
//          root attributes: scene, millsim_version
// Types: every string attribute (units, names, /meta) is a variable-length UTF-8 string; the
// seed is a uint64 attribute; the columns that count things (particles, contact_pairs,
// wall_contacts, breakage_events, outlet_count) are uint64 datasets; the rest are doubles.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "geometry/surface_mesh.h"
#include "particles/particle_store.h"

namespace millsim {

struct SnapshotInfo {
  std::string group;  // "/snapshots/s000000000"
  std::int64_t step;
  double time_s;
  std::size_t particle_count;
  bool breakage = false;  // the snapshot has remaining_capacity and generation
  bool gas = false;       // the snapshot has the gas field
};

// The gas grid the snapshots' gas fields live on, and the geometry's size, for run.xdmf.
struct XdmfExtras {
  std::array<int, 3> gas_cells{0, 0, 0};  // nx, ny, nz; 0 = no gas
  Vec3 gas_origin_m, gas_spacing_m;
  bool gas_compressible = false;  // the gas fields include density, temperature and Mach number
  int dust_classes = 0;           // the gas fields include the dust ledger's concentrations
  std::size_t geometry_points = 0, geometry_triangles = 0;
};

// One snapshot's gas field at the cell centres, x fastest, then y, then z.
struct GasFieldSnapshot {
  std::array<int, 3> cells{0, 0, 0};
  Vec3 origin_m, spacing_m;
  std::vector<Vec3> velocity_m_per_s;
  std::vector<double> pressure_pa, volume_fraction;
  std::vector<std::int32_t> fluid;
  // The compressible model only (empty otherwise): solid cells hold 0.
  std::vector<double> density_kg_per_m3, temperature_k, mach;
  // The dust ledger's concentration (kg/m3), per class (empty without a ledger).
  std::vector<std::vector<double>> dust_kg_per_m3;
};

class H5Writer {
 public:
  // Creates (truncates) the file; throws IoError when it cannot.
  explicit H5Writer(const std::filesystem::path& path);
  ~H5Writer();
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;

  void write_root_attribute(const std::string& name, const std::string& value);
  void write_snapshot(std::int64_t step, double time_s, const ParticleStore& particles);
  // The gas field into the last snapshot's group.
  void write_gas_snapshot(const GasFieldSnapshot& gas);
  // /geometry, once.
  void write_geometry(const SurfaceMesh& mesh);
  void write_timeseries(const std::vector<std::string>& names,
                        const std::vector<std::vector<double>>& columns);
  // One 1-D dataset per name under a new group (e.g. "/psd"): uint64 for a count column (its
  // values must be whole numbers; IoError otherwise), double for the rest.
  void write_columns(const std::string& group, const std::vector<std::string>& names,
                     const std::vector<std::vector<double>>& columns);
  // A uint64 array of any rank under `group` (created when missing), e.g. the impact spectrum.
  void write_count_array(const std::string& group, const std::string& name,
                         const std::vector<std::size_t>& dims,
                         const std::vector<std::uint64_t>& counts);
  // A string attribute (variable-length UTF-8) on an existing group.
  void write_group_attribute(const std::string& group, const std::string& name,
                             const std::string& value);
  // /vertex_index: 0, 1, …, up to the largest snapshot's particle count, the connectivity every
  // snapshot's vertex cells take a slice of in run.xdmf. Call once, after the last snapshot.
  void write_vertex_index();
  // /meta: one attribute per field (the scene as given, the seed, the build): a string, but the
  // seed a uint64 (its text must be an unsigned integer; IoError otherwise).
  void write_meta(const std::vector<std::pair<std::string, std::string>>& fields);
  void close();  // flushes; throws IoError on failure
  // Flushes what is written so far to disk (at a checkpoint, so the file is readable up to it).
  void flush();
  // Copies the snapshots of steps <= `up_to_step` on the schedule (multiples of `every`) from an
  // earlier attempt's file into this one (a resumed run); an attempt's closing snapshot at a
  // stop is off the schedule and left out. Returns how many, or -1 when that file cannot be read
  // (it is left as it is).
  long carry_snapshots(const std::filesystem::path& earlier, std::int64_t up_to_step,
                       std::int64_t every);

  const std::vector<SnapshotInfo>& snapshots() const { return snapshots_; }
  const XdmfExtras& extras() const { return extras_; }

 private:
  std::filesystem::path path_;
  std::int64_t file_ = -1;
  std::vector<SnapshotInfo> snapshots_;
  XdmfExtras extras_;
};

// The XDMF 3 indexes of run.h5 (`h5_name`, a path relative to them), one per kind of data so that
// ParaView's default reader makes each its own pipeline object: the particles (run.xdmf), the gas
// field (gas.xdmf, a uniform grid with the fields at its cells) and the geometry (geometry.xdmf,
// triangles with their part). Xdmf3 merges grids that share one file into unnamed pieces of one
// data set, where the gas box would cover the particles.
void write_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                const std::vector<SnapshotInfo>& snapshots);
void write_gas_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                    const std::vector<SnapshotInfo>& snapshots, const XdmfExtras& extras);
void write_geometry_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                         const XdmfExtras& extras);

}  // namespace millsim
