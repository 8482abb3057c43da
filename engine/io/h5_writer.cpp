#include "io/h5_writer.h"

#include <hdf5.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string_view>
#include <utility>

#include "core/errors.h"

namespace millsim {
namespace {

void check(herr_t status, const std::string& what, const std::filesystem::path& path) {
  if (status < 0) throw IoError("HDF5: " + what + " failed in " + path.string());
}

// A variable-length UTF-8 string: h5py reads it as str (a fixed-length one comes back as bytes,
// and `attrs['units'] == 'm'` is then False).
void write_string_attribute(hid_t object, const char* name, const std::string& value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  const char* text = value.c_str();
  H5Awrite(attr, type, &text);
  H5Aclose(attr), H5Sclose(space), H5Tclose(type);
}

void write_uint64_attribute(hid_t object, const char* name, std::uint64_t value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(object, name, H5T_STD_U64LE, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, H5T_NATIVE_UINT64, &value);
  H5Aclose(attr), H5Sclose(space);
}

// The /meta fields that are numbers, not text: the scene's seed (an unsigned 64-bit integer).
bool is_integer_meta_field(std::string_view name) {
  return name == "seed";
}

// The columns that count things (particles, contacts, events, outlet particles): stored as
// unsigned 64-bit integers. The dust table's dust_count is an equivalent number (its mass over
// that of a sphere of the class size), a fraction, and stays a double like every other column.
bool is_count_column(std::string_view name) {
  static constexpr std::string_view kCounts[] = {
      "particles", "contact_pairs", "wall_contacts", "breakage_events", "outlet_count",
      "parent_id", "fragments",     "generation",    "crushed"};
  return std::find(std::begin(kCounts), std::end(kCounts), name) != std::end(kCounts);
}

// A count held as a double, back to the integer it is; throws on a value that is not one.
std::vector<std::uint64_t> counts_of(const std::string& name, const std::vector<double>& values) {
  std::vector<std::uint64_t> counts(values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (!(values[k] >= 0.0) || values[k] != std::floor(values[k]) || values[k] >= 0x1p64)
      throw IoError("HDF5: column " + name + " holds " + std::to_string(values[k]) + " at " +
                    std::to_string(k) + ", not a count");
    counts[k] = std::uint64_t(values[k]);
  }
  return counts;
}

std::uint64_t parse_uint64(const std::string& name, const std::string& text) {
  std::uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size())
    throw IoError("HDF5: /meta " + name + " = \"" + text + "\" is not an unsigned integer");
  return value;
}

// "gas_dust_c03_kg_per_m3": class 3's concentration in a snapshot's gas fields.
std::string dust_dataset_name(int k) {
  char name[40];
  std::snprintf(name, sizeof name, "gas_dust_c%02d_kg_per_m3", k);
  return name;
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

// The SI unit of a dataset, from its name: the fields named for what they are, the rest by the
// unit suffix of the naming convention (_m, _s, _j, _kg, _pa, _m_per_s); "1" for counts and ratios.
std::string unit_of(std::string_view name) {
  static constexpr std::pair<std::string_view, std::string_view> kNamed[] = {
      {"position", "m"},        {"velocity", "m/s"},     {"angular_velocity", "rad/s"},
      {"speed", "m/s"},         {"diameter", "m"},       {"remaining_capacity", "J/kg"},
      {"gas_velocity", "m/s"},  {"gas_pressure", "Pa"},  {"points", "m"},
      {"gas_density", "kg/m3"}, {"gas_temperature", "K"}};
  for (const auto& [field, unit] : kNamed)
    if (name == field) return std::string(unit);
  static constexpr std::pair<std::string_view, std::string_view> kSuffixes[] = {
      {"_m_per_s", "m/s"}, {"_j_per_kg", "J/kg"}, {"_kg_per_m3", "kg/m3"}, {"_m", "m"},
      {"_s", "s"},         {"_j", "J"},           {"_kg", "kg"},           {"_pa", "Pa"}};
  for (const auto& [suffix, unit] : kSuffixes)
    if (ends_with(name, suffix)) return std::string(unit);
  return "1";
}

// Creation properties of a dataset or group (`property_class`: H5P_DATASET_CREATE or
// H5P_GROUP_CREATE) without HDF5's modification times, so that a run writes the same bytes
// whenever and on however many threads it runs. Closed by the caller.
hid_t untimed_creation(hid_t property_class) {
  const hid_t properties = H5Pcreate(property_class);
  H5Pset_obj_track_times(properties, false);
  return properties;
}

// H5Gcreate2 without modification times.
hid_t create_group(hid_t parent, const char* name) {
  const hid_t properties = untimed_creation(H5P_GROUP_CREATE);
  const hid_t group = H5Gcreate2(parent, name, H5P_DEFAULT, properties, H5P_DEFAULT);
  H5Pclose(properties);
  return group;
}

void write_dataset(hid_t group, const char* name, hid_t mem_type, hid_t file_type, int rank,
                   const hsize_t* dims, const void* data, const std::filesystem::path& path) {
  const hid_t space = H5Screate_simple(rank, dims, nullptr);
  const hid_t properties = untimed_creation(H5P_DATASET_CREATE);
  const hid_t set = H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  H5Pclose(properties);
  if (set < 0) {
    H5Sclose(space);
    throw IoError(std::string("HDF5: cannot create dataset ") + name + " in " + path.string());
  }
  const herr_t status =
      dims[0] == 0 ? 0 : H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  write_string_attribute(set, "units", unit_of(name));
  H5Dclose(set);
  H5Sclose(space);
  check(status, std::string("writing ") + name, path);
}

template <class T>
void write_scalar_attribute(hid_t object, const char* name, hid_t type, T value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, type, &value);
  H5Aclose(attr);
  H5Sclose(space);
}

}  // namespace

H5Writer::H5Writer(const std::filesystem::path& path) : path_(path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become IoError, not stderr noise
  file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file_ < 0) throw IoError("cannot create " + path.string());
  const hid_t g = create_group(file_, "/snapshots");
  if (g < 0) throw IoError("HDF5: cannot create /snapshots in " + path.string());
  H5Gclose(g);
}

H5Writer::~H5Writer() {
  if (file_ >= 0) H5Fclose(file_);
}

void H5Writer::write_root_attribute(const std::string& name, const std::string& value) {
  write_string_attribute(file_, name.c_str(), value);
}

void H5Writer::write_meta(const std::vector<std::pair<std::string, std::string>>& fields) {
  const hid_t g = create_group(file_, "/meta");
  if (g < 0) throw IoError("HDF5: cannot create /meta in " + path_.string());
  try {
    for (const auto& [name, value] : fields) {
      if (is_integer_meta_field(name))
        write_uint64_attribute(g, name.c_str(), parse_uint64(name, value));
      else
        write_string_attribute(g, name.c_str(), value);
    }
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
}

void H5Writer::write_snapshot(std::int64_t step, double time_s, const ParticleStore& p) {
  char name[64];
  std::snprintf(name, sizeof name, "/snapshots/s%09lld", static_cast<long long>(step));
  const hid_t g = create_group(file_, name);
  if (g < 0) throw IoError(std::string("HDF5: cannot create ") + name + " in " + path_.string());
  const std::size_t n = p.size();
  const hsize_t dims3[2] = {n, 3}, dims1[1] = {n};
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  std::vector<double> diameter(n), speed(n);
  std::vector<int> material(n), generation;
  std::vector<Vec3> velocity(n), angular_velocity(n);
  for (std::size_t i = 0; i < n; ++i) {
    diameter[i] = 2.0 * p.radius_m[i], material[i] = p.material[i];
    velocity[i] = p.motion[i].velocity_m_per_s;
    angular_velocity[i] = p.motion[i].angular_velocity_rad_per_s;
    speed[i] = norm(velocity[i]);
  }
  if (p.has_breakage_state) generation.assign(p.generation.begin(), p.generation.end());
  try {
    write_dataset(g, "position", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 2, dims3, p.position_m.data(),
                  path_);
    write_dataset(g, "velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 2, dims3, velocity.data(),
                  path_);
    write_dataset(g, "angular_velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 2, dims3,
                  angular_velocity.data(), path_);
    write_dataset(g, "diameter", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 1, dims1, diameter.data(),
                  path_);
    write_dataset(g, "id", H5T_NATIVE_UINT64, H5T_STD_U64LE, 1, dims1, p.id.data(), path_);
    write_dataset(g, "material", H5T_NATIVE_INT, H5T_STD_I32LE, 1, dims1, material.data(), path_);
    write_dataset(g, "speed", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 1, dims1, speed.data(), path_);
    if (p.has_breakage_state) {
      write_dataset(g, "remaining_capacity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 1, dims1,
                    p.remaining_capacity_j_per_kg.data(), path_);
      write_dataset(g, "generation", H5T_NATIVE_INT, H5T_STD_I32LE, 1, dims1, generation.data(),
                    path_);
    }
    write_scalar_attribute(g, "step", H5T_NATIVE_INT64, static_cast<std::int64_t>(step));
    write_scalar_attribute(g, "time_s", H5T_NATIVE_DOUBLE, time_s);
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
  snapshots_.push_back({name, step, time_s, n, p.has_breakage_state});
}

void H5Writer::write_gas_snapshot(const GasFieldSnapshot& gas) {
  if (snapshots_.empty()) return;
  const hid_t g = H5Gopen2(file_, snapshots_.back().group.c_str(), H5P_DEFAULT);
  if (g < 0)
    throw IoError("HDF5: cannot open " + snapshots_.back().group + " in " + path_.string());
  const hsize_t cells[4] = {hsize_t(gas.cells[2]), hsize_t(gas.cells[1]), hsize_t(gas.cells[0]), 3};
  try {
    write_dataset(g, "gas_velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 4, cells,
                  gas.velocity_m_per_s.data(), path_);
    write_dataset(g, "gas_pressure", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3, cells,
                  gas.pressure_pa.data(), path_);
    write_dataset(g, "gas_volume_fraction", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3, cells,
                  gas.volume_fraction.data(), path_);
    write_dataset(g, "gas_fluid", H5T_NATIVE_INT32, H5T_STD_I32LE, 3, cells, gas.fluid.data(),
                  path_);
    if (!gas.mach.empty()) {
      write_dataset(g, "gas_density", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3, cells,
                    gas.density_kg_per_m3.data(), path_);
      write_dataset(g, "gas_temperature", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3, cells,
                    gas.temperature_k.data(), path_);
      write_dataset(g, "gas_mach", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3, cells, gas.mach.data(),
                    path_);
    }
    for (std::size_t k = 0; k < gas.dust_kg_per_m3.size(); ++k)
      write_dataset(g, dust_dataset_name(int(k)).c_str(), H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3,
                    cells, gas.dust_kg_per_m3[k].data(), path_);
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
  snapshots_.back().gas = true;
  extras_.gas_cells = gas.cells;
  extras_.gas_origin_m = gas.origin_m;
  extras_.gas_spacing_m = gas.spacing_m;
  extras_.gas_compressible = !gas.mach.empty();
  extras_.dust_classes = int(gas.dust_kg_per_m3.size());
}

void H5Writer::write_geometry(const SurfaceMesh& mesh) {
  if (mesh.triangles.empty()) return;
  const hid_t g = create_group(file_, "/geometry");
  if (g < 0) throw IoError("HDF5: cannot create /geometry in " + path_.string());
  std::vector<std::int64_t> triangles;
  for (const auto& t : mesh.triangles) triangles.insert(triangles.end(), t.begin(), t.end());
  const hsize_t points[2] = {mesh.points_m.size(), 3}, cells[2] = {mesh.triangles.size(), 3};
  std::string names;
  for (const std::string& n : mesh.part_names) names.append(n).append("\n");
  try {
    write_dataset(g, "points", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 2, points, mesh.points_m.data(),
                  path_);
    write_dataset(g, "triangles", H5T_NATIVE_INT64, H5T_STD_I64LE, 2, cells, triangles.data(),
                  path_);
    write_dataset(g, "part", H5T_NATIVE_INT32, H5T_STD_I32LE, 1, cells, mesh.part.data(), path_);
    write_string_attribute(g, "parts", names);
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
  extras_.geometry_points = mesh.points_m.size();
  extras_.geometry_triangles = mesh.triangles.size();
}

void H5Writer::flush() {
  if (H5Fflush(file_, H5F_SCOPE_GLOBAL) < 0) throw IoError("HDF5: cannot flush " + path_.string());
}

long H5Writer::carry_snapshots(const std::filesystem::path& earlier, std::int64_t up_to_step,
                               std::int64_t every) {
  const hid_t old = H5Fopen(earlier.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (old < 0) return -1;
  const hid_t group = H5Gopen2(old, "/snapshots", H5P_DEFAULT);
  if (group < 0) {
    H5Fclose(old);
    return -1;
  }
  hsize_t count = 0;
  H5Gget_num_objs(group, &count);
  long carried = 0;
  for (hsize_t k = 0; k < count; ++k) {
    char name[64];
    if (H5Gget_objname_by_idx(group, k, name, sizeof name) <= 0) continue;
    const hid_t g = H5Gopen2(group, name, H5P_DEFAULT);
    if (g < 0) continue;
    std::int64_t step = -1;
    double time_s = 0.0;
    hsize_t dims[2] = {0, 0};
    const hid_t step_attr = H5Aopen(g, "step", H5P_DEFAULT);
    const hid_t time_attr = H5Aopen(g, "time_s", H5P_DEFAULT);
    const hid_t diameter = H5Dopen2(g, "diameter", H5P_DEFAULT);
    const bool readable = step_attr >= 0 && time_attr >= 0 && diameter >= 0 &&
                          H5Aread(step_attr, H5T_NATIVE_INT64, &step) >= 0 &&
                          H5Aread(time_attr, H5T_NATIVE_DOUBLE, &time_s) >= 0;
    if (diameter >= 0) {
      const hid_t space = H5Dget_space(diameter);
      H5Sget_simple_extent_dims(space, dims, nullptr);
      H5Sclose(space);
      H5Dclose(diameter);
    }
    const bool breakage = H5Lexists(g, "generation", H5P_DEFAULT) > 0;
    const bool gas = H5Lexists(g, "gas_pressure", H5P_DEFAULT) > 0;
    if (step_attr >= 0) H5Aclose(step_attr);
    if (time_attr >= 0) H5Aclose(time_attr);
    H5Gclose(g);
    if (!readable || step < 0 || step > up_to_step || step % every != 0) continue;
    const std::string target = std::string("/snapshots/") + name;
    if (H5Ocopy(group, name, file_, target.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0) continue;
    snapshots_.push_back({target, step, time_s, std::size_t(dims[0]), breakage, gas});
    ++carried;
  }
  H5Gclose(group);
  H5Fclose(old);
  std::sort(snapshots_.begin(), snapshots_.end(),
            [](const SnapshotInfo& a, const SnapshotInfo& b) { return a.step < b.step; });
  return carried;
}

void H5Writer::write_timeseries(const std::vector<std::string>& names,
                                const std::vector<std::vector<double>>& columns) {
  write_columns("/timeseries", names, columns);
}

void H5Writer::write_columns(const std::string& group, const std::vector<std::string>& names,
                             const std::vector<std::vector<double>>& columns) {
  const hid_t g = create_group(file_, group.c_str());
  if (g < 0) throw IoError("HDF5: cannot create " + group + " in " + path_.string());
  try {
    for (std::size_t c = 0; c < names.size(); ++c) {
      const hsize_t dims[1] = {columns[c].size()};
      if (is_count_column(names[c])) {
        const std::vector<std::uint64_t> counts = counts_of(names[c], columns[c]);
        write_dataset(g, names[c].c_str(), H5T_NATIVE_UINT64, H5T_STD_U64LE, 1, dims, counts.data(),
                      path_);
      } else {
        write_dataset(g, names[c].c_str(), H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 1, dims,
                      columns[c].data(), path_);
      }
    }
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
}

void H5Writer::write_count_array(const std::string& group, const std::string& name,
                                 const std::vector<std::size_t>& dims,
                                 const std::vector<std::uint64_t>& counts) {
  const hid_t g = H5Lexists(file_, group.c_str(), H5P_DEFAULT) > 0
                      ? H5Gopen2(file_, group.c_str(), H5P_DEFAULT)
                      : create_group(file_, group.c_str());
  if (g < 0) throw IoError("HDF5: cannot create " + group + " in " + path_.string());
  std::vector<hsize_t> extent(dims.begin(), dims.end());
  try {
    write_dataset(g, name.c_str(), H5T_NATIVE_UINT64, H5T_STD_U64LE, int(extent.size()),
                  extent.data(), counts.data(), path_);
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  H5Gclose(g);
}

void H5Writer::write_group_attribute(const std::string& group, const std::string& name,
                                     const std::string& value) {
  const hid_t g = H5Gopen2(file_, group.c_str(), H5P_DEFAULT);
  if (g < 0) throw IoError("HDF5: no group " + group + " in " + path_.string());
  write_string_attribute(g, name.c_str(), value);
  H5Gclose(g);
}

void H5Writer::write_vertex_index() {
  std::size_t largest = 1;
  for (const SnapshotInfo& s : snapshots_) largest = std::max(largest, s.particle_count);
  std::vector<std::int64_t> index(largest);
  for (std::size_t i = 0; i < largest; ++i) index[i] = std::int64_t(i);
  const hsize_t dims[1] = {largest};
  write_dataset(file_, "vertex_index", H5T_NATIVE_INT64, H5T_STD_I64LE, 1, dims, index.data(),
                path_);
}

void H5Writer::close() {
  if (file_ < 0) return;
  const herr_t status = H5Fclose(file_);
  file_ = -1;
  check(status, "closing the file", path_);
}

namespace {

// One HDF5 dataset as an XDMF DataItem.
void hdf_item(std::ostream& out, const std::string& h5_name, const std::string& path,
              const std::string& dims, const char* type, int precision) {
  out << "       <DataItem Dimensions=\"" << dims << "\" NumberType=\"" << type << "\" Precision=\""
      << precision << "\" Format=\"HDF\">" << h5_name << ":" << path << "</DataItem>\n";
}

void attribute_item(std::ostream& out, const std::string& h5_name, const char* name, bool vector,
                    const char* center, const std::string& path, const std::string& dims,
                    const char* type, int precision) {
  out << "     <Attribute Name=\"" << name << "\" AttributeType=\""
      << (vector ? "Vector" : "Scalar") << "\" Center=\"" << center << "\">\n";
  hdf_item(out, h5_name, path, dims, type, precision);
  out << "     </Attribute>\n";
}

void open_xdmf(std::ofstream& out, const std::filesystem::path& path) {
  if (!out) throw IoError("cannot write " + path.string());
  out.precision(17);  // times and coordinates as written in run.h5, to the last bit
  out << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n";
}

void close_xdmf(std::ofstream& out, const std::filesystem::path& path) {
  out << " </Domain>\n</Xdmf>\n";
  if (!out) throw IoError("cannot write " + path.string());
}

// The XDMF Dimensions of a snapshot's N×3 datasets (position, velocity, angular_velocity).
// An empty snapshot (a fed case before its first particle, or after the last has left) stays a
// time step of the particle collection, so that ParaView shows no particles at that time rather
// than the nearest non-empty frame; but its N×3 items are described flat, as "0". ParaView's
// Xdmf3 reader divides an array's size by the product of its leading dimensions when it reads
// that array again (XdmfArray::getDimensions), and "0 3" makes that a division by zero: SIGFPE
// on the first frame revisited (stepping back, looping). A flat "0" names the same zero values.
std::string vector_dimensions(const SnapshotInfo& s) {
  return s.particle_count == 0 ? "0" : std::to_string(s.particle_count) + " 3";
}

}  // namespace

void write_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                const std::vector<SnapshotInfo>& snapshots) {
  std::ofstream out(xdmf_path);
  open_xdmf(out, xdmf_path);
  out << "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  struct Field {
    const char* name;  // dataset and attribute name
    bool vector;       // n × 3
    const char* type;  // XDMF NumberType
    int precision;     // bytes
    bool breakage_only;
  };
  static constexpr Field kFields[] = {
      {"id", false, "UInt", 8, false},
      {"material", false, "Int", 4, false},
      {"diameter", false, "Float", 8, false},
      {"velocity", true, "Float", 8, false},
      {"angular_velocity", true, "Float", 8, false},
      {"speed", false, "Float", 8, false},
      {"remaining_capacity", false, "Float", 8, true},
      {"generation", false, "Int", 4, true},
  };
  std::size_t largest = 1;  // the length of /vertex_index (H5Writer::write_vertex_index)
  for (const SnapshotInfo& s : snapshots) largest = std::max(largest, s.particle_count);
  for (const SnapshotInfo& s : snapshots) {
    const std::string n = std::to_string(s.particle_count), n3 = vector_dimensions(s);
    // One vertex cell per particle (Polyvertex, one node each): ParaView's default reader
    // draws them as soon as the file is opened.
    out << "   <Grid Name=\"" << s.group.substr(s.group.rfind('/') + 1)
        << "\" GridType=\"Uniform\">\n"
        << "    <Time Value=\"" << s.time_s << "\"/>\n"
        << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
        << "\" NodesPerElement=\"1\">\n";
    if (s.particle_count > 0)  // the first n entries of /vertex_index
      out << "      <DataItem ItemType=\"HyperSlab\" Dimensions=\"" << n
          << "\" Type=\"HyperSlab\">\n"
          << "        <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 " << n << "</DataItem>\n"
          << "        <DataItem Dimensions=\"" << largest
          << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << h5_name
          << ":/vertex_index</DataItem>\n      </DataItem>\n";
    out << "    </Topology>\n    <Geometry GeometryType=\"XYZ\">\n";
    hdf_item(out, h5_name, s.group + "/position", n3, "Float", 8);
    out << "    </Geometry>\n";
    for (const Field& f : kFields)
      if (!f.breakage_only || s.breakage)
        attribute_item(out, h5_name, f.name, f.vector, "Node", s.group + "/" + f.name,
                       f.vector ? n3 : n, f.type, f.precision);
    out << "   </Grid>\n";
  }
  out << "  </Grid>\n";
  close_xdmf(out, xdmf_path);
}

void write_gas_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                    const std::vector<SnapshotInfo>& snapshots, const XdmfExtras& extras) {
  std::ofstream out(xdmf_path);
  open_xdmf(out, xdmf_path);
  const std::array<int, 3>& c = extras.gas_cells;
  const std::string cells =
      std::to_string(c[2]) + " " + std::to_string(c[1]) + " " + std::to_string(c[0]);
  const Vec3& o = extras.gas_origin_m;
  const Vec3& h = extras.gas_spacing_m;
  out << "  <Grid Name=\"gas\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const SnapshotInfo& s : snapshots) {
    if (!s.gas) continue;
    // The gas cells: a uniform grid of (nx+1)(ny+1)(nz+1) corners, the fields at the cells.
    out << "   <Grid Name=\"" << s.group.substr(s.group.rfind('/') + 1)
        << "\" GridType=\"Uniform\">\n"
        << "    <Time Value=\"" << s.time_s << "\"/>\n"
        << "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << c[2] + 1 << " "
        << c[1] + 1 << " " << c[0] + 1 << "\"/>\n"
        << "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
        << "       <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">"
        << o.z << " " << o.y << " " << o.x << "</DataItem>\n"
        << "       <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">"
        << h.z << " " << h.y << " " << h.x << "</DataItem>\n"
        << "    </Geometry>\n";
    attribute_item(out, h5_name, "velocity", true, "Cell", s.group + "/gas_velocity", cells + " 3",
                   "Float", 8);
    attribute_item(out, h5_name, "pressure", false, "Cell", s.group + "/gas_pressure", cells,
                   "Float", 8);
    attribute_item(out, h5_name, "volume_fraction", false, "Cell", s.group + "/gas_volume_fraction",
                   cells, "Float", 8);
    attribute_item(out, h5_name, "fluid", false, "Cell", s.group + "/gas_fluid", cells, "Int", 4);
    if (extras.gas_compressible)
      for (const char* field : {"density", "temperature", "mach"})
        attribute_item(out, h5_name, field, false, "Cell", s.group + "/gas_" + field, cells,
                       "Float", 8);
    for (int k = 0; k < extras.dust_classes; ++k)
      attribute_item(out, h5_name, dust_dataset_name(k).substr(4).c_str(), false, "Cell",
                     s.group + "/" + dust_dataset_name(k), cells, "Float", 8);
    out << "   </Grid>\n";
  }
  out << "  </Grid>\n";
  close_xdmf(out, xdmf_path);
}

void write_geometry_xdmf(const std::filesystem::path& xdmf_path, const std::string& h5_name,
                         const XdmfExtras& extras) {
  std::ofstream out(xdmf_path);
  open_xdmf(out, xdmf_path);
  const std::string t = std::to_string(extras.geometry_triangles);
  out << "  <Grid Name=\"geometry\" GridType=\"Uniform\">\n"
      << "    <Topology TopologyType=\"Triangle\" NumberOfElements=\"" << t << "\">\n";
  hdf_item(out, h5_name, "/geometry/triangles", t + " 3", "Int", 8);
  out << "    </Topology>\n    <Geometry GeometryType=\"XYZ\">\n";
  hdf_item(out, h5_name, "/geometry/points", std::to_string(extras.geometry_points) + " 3", "Float",
           8);
  out << "    </Geometry>\n";
  attribute_item(out, h5_name, "part", false, "Cell", "/geometry/part", t, "Int", 4);
  out << "  </Grid>\n";
  close_xdmf(out, xdmf_path);
}

}  // namespace millsim
