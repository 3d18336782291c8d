#include "sim/world.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "base/atomic_file.hpp"

namespace ambler::sim {

void World::ModelDeleter::operator()(mjModel_* m) const { mj_deleteModel(m); }
void World::DataDeleter::operator()(mjData_* d) const { mj_deleteData(d); }

World::World(mjModel_* model) : model_(model), data_(mj_makeData(model)) {
  if (!data_) throw std::runtime_error("MuJoCo: could not allocate mjData");
  // mj_ray reads geom_xpos/geom_xmat, which only mj_forward fills in.
  mj_forward(model_.get(), data_.get());
}
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

World World::load(const std::filesystem::path& xml) {
  if (!std::filesystem::exists(xml))
    throw std::runtime_error(xml.string() + ": cannot open file");
  std::array<char, 1000> err{};
  mjModel* m = mj_loadXML(xml.c_str(), nullptr, err.data(), int(err.size()));
  if (!m) throw std::runtime_error(xml.string() + ": MuJoCo: " + err.data());
  return World(m);
}

World World::fromString(const std::string& xml, const std::filesystem::path& dir) {
  // MuJoCo 2.2.2 loads only from files (or its VFS): write a temporary file beside the assets.
  const auto tmp = dir / ("ambler_inline_" + std::to_string(std::hash<std::string>{}(xml)) + ".xml");
  {
    std::ofstream out(tmp);
    out << xml;
    if (!out) throw std::runtime_error(tmp.string() + ": cannot write");
  }
  try {
    World w = load(tmp);
    std::filesystem::remove(tmp);
    return w;
  } catch (...) {
    std::filesystem::remove(tmp);
    throw;
  }
}

int World::geomCount() const { return model_->ngeom; }

void World::saveLastXml(const std::filesystem::path& xml) const {
  const auto tmp = xml.string() + ".tmp";
  std::array<char, 1000> err{};
  if (!mj_saveLastXML(tmp.c_str(), model_.get(), err.data(), int(err.size())))
    throw std::runtime_error(xml.string() + ": MuJoCo could not save the model: " + err.data());
  std::filesystem::rename(tmp, xml);
}

std::optional<double> World::ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                 int* geom) const {
  int id = -1;
  const mjtNum t = mj_ray(model_.get(), data_.get(), origin.data(), dir.data(), nullptr, 1, -1, &id);
  if (geom) *geom = id;
  if (t < 0) return std::nullopt;
  return t;
}

namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// MuJoCo normalises hfield data to [0, 1]; writing it already normalised makes that a no-op, so
// the surface is exactly z = pos.z + data·elev with these floats.
struct HfieldData {
  std::vector<float> normalised;
  double z_min, elev;
};

HfieldData normalise(const terrains::Heightfield& hf) {
  HfieldData out{{}, hf.minHeight(), hf.maxHeight() - hf.minHeight()};
  out.normalised.resize(std::size_t(hf.rows()) * hf.cols());
  const double scale = out.elev > 0 ? 1.0 / out.elev : 0.0;
  for (int r = 0; r < hf.rows(); ++r)
    for (int c = 0; c < hf.cols(); ++c)
      out.normalised[std::size_t(r) * hf.cols() + c] =
          std::clamp(float((hf.at(r, c) - out.z_min) * scale), 0.0f, 1.0f);
  // elev must be positive for MuJoCo; a flat field has all data 0, so any value gives z_min.
  if (out.elev <= 0) out.elev = 1e-6;
  return out;
}

std::string rockName(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "rock_%04zu", i);
  return buf;
}

std::string stlBytes(const terrains::Rock& rock) {
  std::string bytes(80, '\0');
  const std::string header = "ambler rock (binary STL, metres, relative to the geom position)";
  std::memcpy(bytes.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  auto put = [&bytes](const void* p, std::size_t n) { bytes.append(static_cast<const char*>(p), n); };
  const std::uint32_t n = std::uint32_t(rock.faces.size());
  put(&n, 4);
  for (const auto& f : rock.faces) {
    const Eigen::Vector3d a = rock.vertices[f[0]], b = rock.vertices[f[1]], c = rock.vertices[f[2]];
    const Eigen::Vector3f nrm = (b - a).cross(c - a).normalized().cast<float>();
    put(nrm.data(), 12);
    for (const auto* v : {&a, &b, &c}) {
      const Eigen::Vector3f vf = v->cast<float>();
      put(vf.data(), 12);
    }
    const std::uint16_t attr = 0;
    put(&attr, 2);
  }
  return bytes;
}

}  // namespace

std::string worldXml(const terrains::Terrain& terrain, const std::string& name) {
  const auto& hf = terrain.ground;
  const HfieldData data = normalise(hf);
  const double rx = 0.5 * (hf.xMax() - hf.xMin()), ry = 0.5 * (hf.yMax() - hf.yMin());
  const double cx = 0.5 * (hf.xMax() + hf.xMin()), cy = 0.5 * (hf.yMax() + hf.yMin());
  const double base = std::max(0.5, 0.5 * data.elev);
  std::ostringstream x;
  x << "<mujoco model=\"" << name << "\">\n"
    << "  <!-- written by ambler: the terrain heights are in terrain.bin (MuJoCo's binary hfield\n"
    << "       format, normalised to [0,1]); z = pos.z + data * size[2]. -->\n"
    << "  <compiler angle=\"radian\"/>\n"
    << "  <visual><headlight ambient=\"0.35 0.35 0.35\"/><map znear=\"0.01\"/></visual>\n"
    << "  <asset>\n"
    << "    <hfield name=\"terrain\" file=\"terrain.bin\" size=\"" << num(rx) << ' ' << num(ry) << ' '
    << num(data.elev) << ' ' << num(base) << "\"/>\n";
  for (std::size_t i = 0; i < terrain.rocks.size(); ++i)
    x << "    <mesh name=\"" << rockName(i) << "\" file=\"" << rockName(i) << ".stl\"/>\n";
  x << "  </asset>\n  <worldbody>\n"
    << "    <light directional=\"true\" pos=\"0 0 30\" dir=\"0.3 0.2 -1\"/>\n"
    << "    <geom name=\"terrain\" type=\"hfield\" hfield=\"terrain\" pos=\"" << num(cx) << ' '
    << num(cy) << ' ' << num(data.z_min) << "\" rgba=\"0.76 0.52 0.36 1\"/>\n";
  for (std::size_t i = 0; i < terrain.rocks.size(); ++i) {
    const auto& c = terrain.rocks[i].center;
    x << "    <geom name=\"" << rockName(i) << "\" type=\"mesh\" mesh=\"" << rockName(i)
      << "\" pos=\"" << num(c.x()) << ' ' << num(c.y()) << ' ' << num(c.z())
      << "\" rgba=\"0.45 0.36 0.31 1\"/>\n";
  }
  x << "  </worldbody>\n</mujoco>\n";
  return x.str();
}

std::filesystem::path writeWorld(const terrains::Terrain& terrain, const std::filesystem::path& dir,
                                 const std::string& name) {
  std::filesystem::create_directories(dir);
  const auto& hf = terrain.ground;
  const HfieldData data = normalise(hf);
  std::string bin(8, '\0');
  const std::int32_t dims[2] = {hf.rows(), hf.cols()};
  std::memcpy(bin.data(), dims, 8);
  bin.append(reinterpret_cast<const char*>(data.normalised.data()),
             data.normalised.size() * sizeof(float));
  base::writeFileAtomic(dir / "terrain.bin", bin);
  for (std::size_t i = 0; i < terrain.rocks.size(); ++i)
    base::writeFileAtomic(dir / (rockName(i) + ".stl"), stlBytes(terrain.rocks[i]));
  const auto xml = dir / "world.xml";
  base::writeFileAtomic(xml, worldXml(terrain, name));
  return xml;
}

}  // namespace ambler::sim
