#include "region_tags.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

namespace tetrascope::storage::detail {

namespace {
bool same_name(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}
}  // namespace

std::optional<size_t> find_region_array(const std::vector<std::string>& names, const std::vector<uint32_t>& components) {
  for (size_t a = 0; a < names.size(); ++a) {
    if (components[a] != 1) continue;
    for (std::string_view known : kRegionArrayNames)
      if (same_name(names[a], known)) return a;
  }
  return std::nullopt;
}

void SurfaceRegions::note(const CellBatch& batch, uint64_t cell) {
  const size_t last = batch.size() - 1;
  const uint8_t type = batch.types[last];
  const uint64_t begin = batch.offsets[last], count = batch.offsets[last + 1] - begin;
  if (!((type == kVtkTriangle && count == 3) || (type == kVtkQuad && count == 4))) return;
  std::array<uint32_t, 4> c{kNoCorner, kNoCorner, kNoCorner, kNoCorner};
  std::copy_n(batch.nodes.begin() + static_cast<ptrdiff_t>(begin), count, c.begin());
  cells_.push_back(cell);
  corners_.push_back(c);
}

FaceTags SurfaceRegions::resolve(ValueStream& values, bool integral, const std::string& array) const {
  constexpr size_t kBlock = 1 << 16;
  std::vector<int64_t> ids(cells_.size()), ints(integral ? kBlock : 0);
  std::vector<float> reals(integral ? 0 : kBlock);
  const std::string what = "cell array '" + array + "' (region ids)";
  uint64_t first = 0;  // the cell of the block's first value
  for (size_t s = 0; s < cells_.size();) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(kBlock, cells_.back() + 1 - first));
    if (integral) values.read_int(ints.data(), n, what);
    else values.read_float(reals.data(), n, false, what);
    for (; s < cells_.size() && cells_[s] < first + n; ++s) {
      const size_t at = static_cast<size_t>(cells_[s] - first);
      if (integral) {
        ids[s] = ints[at];
        continue;
      }
      const float v = reals[at];
      if (!std::isfinite(v) || v != std::floor(v) || std::fabs(v) > 2147483647.0f) {
        values.fail(what + ": surface cell " + std::to_string(cells_[s]) + " has the value " + std::to_string(v) + ", not a whole number");
      }
      ids[s] = static_cast<int64_t>(v);
    }
    first += n;
  }
  std::map<int64_t, uint32_t> tag_of;
  for (int64_t id : ids) tag_of.emplace(id, 0);
  FaceTags tags;
  for (auto& [id, tag] : tag_of) tag = tags.tag("region " + std::to_string(id));
  for (size_t s = 0; s < cells_.size(); ++s) {
    const std::array<uint32_t, 4>& c = corners_[s];
    const uint32_t tag = tag_of[ids[s]];
    if (c[3] == kNoCorner) {
      tags.add(tag, c[0], c[1], c[2]);
      continue;
    }
    const size_t k = static_cast<size_t>(std::min_element(c.begin(), c.end()) - c.begin());
    tags.add(tag, c[k], c[(k + 1) % 4], c[(k + 2) % 4]);
    tags.add(tag, c[k], c[(k + 2) % 4], c[(k + 3) % 4]);
  }
  return tags;
}

}  // namespace tetrascope::storage::detail
