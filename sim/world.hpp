#pragma once
// The MuJoCo world: an immutable model (and the state after mj_forward) loaded from MJCF.
// MuJoCo stays behind this interface: no header of sim/ includes mujoco.h.
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "terrains/terrain.hpp"

struct mjModel_;
struct mjData_;

namespace ambler::sim {

class World {
 public:
  // Loads an MJCF file and runs mj_forward. Throws std::runtime_error with MuJoCo's message.
  static World load(const std::filesystem::path& xml);
  // Loads MJCF text (paths in it resolve against `dir`).
  static World fromString(const std::string& xml, const std::filesystem::path& dir = ".");

  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  ~World();

  const mjModel_* model() const { return model_.get(); }
  const mjData_* data() const { return data_.get(); }
  int geomCount() const;

  // Writes the MJCF of the most recently loaded model (MuJoCo's mj_saveLastXML) to `xml`,
  // atomically. Asset paths are written as the source gave them.
  void saveLastXml(const std::filesystem::path& xml) const;

  // mj_ray over every geom (the plain MuJoCo reference): distance along the unit `dir`, or
  // nullopt. `geom` receives the id of the geom hit.
  std::optional<double> ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                            int* geom = nullptr) const;

 private:
  struct ModelDeleter { void operator()(mjModel_* m) const; };
  struct DataDeleter { void operator()(mjData_* d) const; };
  World(mjModel_* model);
  std::unique_ptr<mjModel_, ModelDeleter> model_;
  std::unique_ptr<mjData_, DataDeleter> data_;
};

// Writes `terrain` as a MuJoCo world in `dir`: world.xml, terrain.bin (MuJoCo's binary hfield:
// int32 rows, int32 cols, float32 heights normalised to [0,1], row 0 at the smallest y) and one
// binary STL per rock. Files are written to temporaries and renamed. Returns the XML's path.
std::filesystem::path writeWorld(const terrains::Terrain& terrain, const std::filesystem::path& dir,
                                 const std::string& name);

// The MJCF text of the world writeWorld() writes (file names relative to its directory).
std::string worldXml(const terrains::Terrain& terrain, const std::string& name);

}  // namespace ambler::sim
