// Boundary regions: the boundary of a mesh split into the pieces a user shows and hides one by
// one, as ParaView lists a CFD case's patches (a far field, a symmetry plane, a wing).
//
// Regions come from the input's face tags where it has them (a store's boundary_tags.bin: a
// Gmsh physical surface, an OpenFOAM patch, an Exodus II side set; one region a tag) and
// otherwise from sharp feature edges: a flood fill over the boundary triangles across the edges whose dihedral
// angle is below the feature angle. Regions are found once per dataset, on its full
// resolution boundary, and carried to other meshes of the same domain (a cut's simplified
// boundary, a clipped scene) by the nearest boundary triangle (RegionMap::classify).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::renderer {

struct SceneMesh;

// A boundary face that belongs to no region (a clip plane's face, a face far from the
// dataset's boundary): never hidden.
constexpr uint32_t kNoRegion = 0xFFFFFFFFu;

// 40 degrees: a curved surface tessellated as coarsely as a 12-sided cylinder (30 degrees from
// facet to facet) stays one region, while the right angles where a symmetry plane meets a far
// field, a body meets a wall or two faces of a box meet split. ParaView's feature edges take
// 30; the coarse far fields of CFD meshes need the margin.
constexpr double kFeatureAngleDegrees = 40;
// A region of fewer triangles than this share of the boundary (and at least kMinRegionTriangles)
// is merged into the neighbour it shares the longest border with: a rounded trailing edge or a
// chamfer is not a region a user wants to hide alone.
constexpr double kMinRegionShare = 0.001;
constexpr uint32_t kMinRegionTriangles = 8;
// The regions kept at most, smallest merged first: a list a user can read.
constexpr uint32_t kMaxRegions = 64;

struct RegionOptions {
  double feature_angle_degrees = kFeatureAngleDegrees;
  double min_region_share = kMinRegionShare;
  uint32_t min_region_triangles = kMinRegionTriangles;
  uint32_t max_regions = kMaxRegions;
};

struct BoundaryRegion {
  uint32_t id = 0;
  std::string name;          // the tag's name when tags named it; else empty ("region N" in the viewer)
  uint64_t triangles = 0;
  double area = 0;
  storage::Bounds bounds;
  // On the domain's bounding box: a triangle of it lies in a face of the box, or its vertices
  // reach two faces of the box or more. A far field or a symmetry plane does; a body inside
  // does not, even one mounted on a wall (a wing on its symmetry plane reaches one face, along
  // an edge).
  bool touches_domain_box = false;
};

// The regions of one boundary: per triangle its region, and each region's summary. Regions
// are numbered by decreasing area.
struct BoundaryRegions {
  std::vector<BoundaryRegion> regions;
  std::vector<uint32_t> triangle_region;  // per input triangle
};

// Splits `triangles` (outward boundary faces over the interleaved positions `xyz`) into regions.
// With `tags` (one per triangle), two triangles share a region exactly when they share a tag,
// however its triangles lie; `tag_names` (indexed by tag, may be shorter)
// names them. Without, by feature edges (see the top of this file). Input is trusted (the
// boundary of a checked mesh).
BoundaryRegions find_boundary_regions(std::span<const float> xyz, std::span<const std::array<uint32_t, 3>> triangles,
                                      std::span<const uint32_t> tags = {}, std::span<const std::string> tag_names = {},
                                      const RegionOptions& options = {});

// Where a boundary's regions came from: the input's face tags (boundary_tags.bin in a store,
// the reader's tags for a mesh file), or sharp edges where it has none.
enum class RegionSource { kSharpEdges, kInputTags };
const char* region_source_name(RegionSource source);  // "sharp edges", "input tags"

// The name of the region of boundary triangles the input's tags leave out.
inline constexpr const char* kUntaggedRegionName = "untagged";

// Per triangle of `triangles`, its tag in `face_tags`, found by its vertex triple: a vertex v
// is `ids[v]` there (`ids` empty: v). A triangle no tag names gets tag `names.size()` - 1 after
// kUntaggedRegionName was appended to `names` (a copy of face_tags.names). Empty when no
// triangle has a tag (regions then come from sharp edges).
std::vector<uint32_t> tags_of_triangles(std::span<const std::array<uint32_t, 3>> triangles, std::span<const uint32_t> ids,
                                        const storage::FaceTags& face_tags, std::vector<std::string>& names);

// The regions of a dataset as a map of its boundary, to carry them to other meshes of the same
// domain. Immutable once built: shared between the views of a dataset.
// Per boundary face of `scene`, 1 where its region is one of `hidden` (ascending ids); empty
// when nothing is hidden or the scene knows no regions.
std::vector<uint8_t> hidden_faces(const SceneMesh& scene, std::span<const uint32_t> hidden);

class RegionMap {
 public:
  // The boundary of `mesh` (its full resolution), split by find_boundary_regions.
  static std::shared_ptr<const RegionMap> from(const storage::TetMesh& mesh, std::span<const uint32_t> tags = {},
                                               std::span<const std::string> tag_names = {}, const RegionOptions& options = {});
  // The regions of `mesh` by the input's tags (mesh.face_tags, or `face_tags` over the ids
  // `ids` gives each vertex), one region a tag named as the input names it; by sharp edges
  // when no boundary triangle is tagged.
  static std::shared_ptr<const RegionMap> tagged(const storage::TetMesh& mesh, const storage::FaceTags& face_tags, std::span<const uint32_t> ids = {},
                                                 const RegionOptions& options = {});
  // The regions of a multiresolution store, on its finest cut (the input mesh) read through a
  // segment cache of its own of `cache_bytes`: by its boundary_tags.bin when it has one
  // (`tags`; without the argument read from the store, storage::BoundaryTagsError when
  // damaged), else by sharp edges. Throws what reading a segment throws.
  static std::shared_ptr<const RegionMap> of_store(const storage::Store& store, const lod::Dag& dag, uint64_t cache_bytes,
                                                   const std::optional<storage::FaceTags>& tags);
  static std::shared_ptr<const RegionMap> of_store(const storage::Store& store, const lod::Dag& dag, uint64_t cache_bytes);
  RegionMap(std::vector<float> corners, BoundaryRegions regions, RegionSource source = RegionSource::kSharpEdges);
  ~RegionMap();
  const std::vector<BoundaryRegion>& regions() const { return regions_.regions; }
  RegionSource source() const { return source_; }
  // The region of each of `scene`'s boundary faces: the region of the nearest boundary
  // triangle of the map facing the same way, within the face's longest edge; kNoRegion for a
  // face with none that near, and for a face in one of `planes` (a clip's cut faces, given as
  // normal and offset, n.x = d). Runs on every core.
  std::vector<uint32_t> classify(const SceneMesh& scene, std::span<const std::array<double, 4>> planes = {}) const;

 private:
  struct Tree;
  std::vector<float> corners_;  // 9 floats a triangle
  BoundaryRegions regions_;
  RegionSource source_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace tetrascope::renderer
