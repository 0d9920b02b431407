// Sharing the segments of a level among the ranks of an MPI launch: which rank
// simplifies which ceiling (longest processing time first, Graham 1969), and the bytes its
// results travel in. Every rank decodes every other rank's results into the same slots, so
// that every rank goes on with the state a build on one rank would have: new vertex ids and
// patch order are assigned after the exchange, in ceiling order (mt_levels.cpp). A ceiling's
// variants (--variants) go to rank 0 alone, which writes them.
//
// The bytes come from the ranks of this launch, the same build of the same binary: they are
// trusted, and a short or long record is a programming error, reported as one.
#include <algorithm>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include "mt_stages.h"

namespace tetrascope::lod::mt {
namespace {

class ByteWriter {
 public:
  template <class T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  template <class T>
  void put_array(std::span<const T> values) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<uint64_t>(values.size());
    const size_t at = bytes_.size();
    bytes_.resize(at + values.size_bytes());
    if (!values.empty()) std::memcpy(bytes_.data() + at, values.data(), values.size_bytes());
  }
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> bytes) : bytes_(bytes) {}
  bool done() const { return at_ == bytes_.size(); }
  template <class T>
  T get() {
    T value;
    std::memcpy(&value, take(sizeof(T)), sizeof(T));
    return value;
  }
  template <class T>
  void get_array(std::vector<T>& out) {
    const uint64_t count = get<uint64_t>();
    if (count > (bytes_.size() - at_) / sizeof(T)) fail();
    out.resize(count);
    if (count) std::memcpy(out.data(), take(count * sizeof(T)), count * sizeof(T));
  }

 private:
  const uint8_t* take(size_t size) {
    if (size > bytes_.size() - at_) fail();
    const uint8_t* p = bytes_.data() + at_;
    at_ += size;
    return p;
  }
  [[noreturn]] static void fail() { throw std::logic_error("MPI exchange: a rank's record is shorter than it says (ranks of different builds?)"); }
  std::span<const uint8_t> bytes_;
  size_t at_ = 0;
};

void encode(const CeilingResult& r, ByteWriter& out) {
  out.put_array<float>(r.mesh.x);
  out.put_array<float>(r.mesh.y);
  out.put_array<float>(r.mesh.z);
  for (const auto& a : r.mesh.attributes) out.put_array<float>(a.values);
  out.put_array<uint32_t>(r.mesh.tets);
  out.put_array<uint32_t>(r.global);
  out.put_array<float>(r.error.field);
  out.put_array<float>(r.error.spatial);
  out.put_array<float>(r.error.mass);
  out.put_array<uint32_t>(r.error.located_tet);
}

// A ceiling's variants travel apart from it (share_results): rank 0 alone writes them.
void encode_variants(const std::vector<VariantMesh>& variants, ByteWriter& out) {
  out.put<uint64_t>(variants.size());
  for (const VariantMesh& v : variants) {
    out.put_array<uint32_t>(v.global);
    out.put_array<float>(v.xyz);
    out.put_array<float>(v.values);
    out.put_array<uint32_t>(v.tets);
  }
}

void decode_variants(ByteReader& in, std::vector<VariantMesh>& variants) {
  const uint64_t count = in.get<uint64_t>();
  if (count > kMaxVariants) throw std::logic_error("MPI exchange: more variants than a segment may have");
  variants.resize(count);
  for (VariantMesh& v : variants) {
    in.get_array(v.global);
    in.get_array(v.xyz);
    in.get_array(v.values);
    in.get_array(v.tets);
  }
}

void decode(ByteReader& in, const std::vector<storage::AttributeInfo>& attributes, CeilingResult& r) {
  in.get_array(r.mesh.x);
  in.get_array(r.mesh.y);
  in.get_array(r.mesh.z);
  r.mesh.attributes.clear();
  for (const auto& info : attributes) {
    r.mesh.attributes.push_back({info, {}});
    in.get_array(r.mesh.attributes.back().values);
  }
  in.get_array(r.mesh.tets);
  in.get_array(r.global);
  in.get_array(r.error.field);
  in.get_array(r.error.spatial);
  in.get_array(r.error.mass);
  in.get_array(r.error.located_tet);
}

void encode(const CeilingTrace& t, ByteWriter& out) {
  out.put<uint64_t>(t.tets);
  out.put<uint64_t>(t.goal);
  std::vector<uint64_t> alive(t.steps.size());
  std::vector<double> cost(t.steps.size());
  for (size_t i = 0; i < t.steps.size(); ++i) std::tie(alive[i], cost[i]) = t.steps[i];
  out.put_array<uint64_t>(alive);
  out.put_array<double>(cost);
}

void decode(ByteReader& in, const std::vector<storage::AttributeInfo>&, CeilingTrace& t) {
  t.tets = in.get<uint64_t>();
  t.goal = in.get<uint64_t>();
  std::vector<uint64_t> alive;
  std::vector<double> cost;
  in.get_array(alive);
  in.get_array(cost);
  if (alive.size() != cost.size()) throw std::logic_error("MPI exchange: a cost trace's columns differ in length");
  t.steps.resize(alive.size());
  for (size_t i = 0; i < alive.size(); ++i) t.steps[i] = {alive[i], cost[i]};
}

// Each rank sends the items it owns, as (index, item) records; the others' are decoded into
// their slots. A rank's bytes are dropped as soon as they are decoded.
template <class Item>
void share(Ranks& ranks, std::span<const uint32_t> owner, std::vector<Item>& items, const std::vector<storage::AttributeInfo>& attributes) {
  const uint32_t me = static_cast<uint32_t>(ranks.rank());
  ByteWriter out;
  for (uint32_t k = 0; k < items.size(); ++k)
    if (owner[k] == me) {
      out.put<uint32_t>(k);
      encode(items[k], out);
    }
  std::vector<std::vector<uint8_t>> gathered = ranks.all_gather(out.bytes());
  for (uint32_t r = 0; r < gathered.size(); ++r) {
    if (r != me) {
      ByteReader in(gathered[r]);
      while (!in.done()) {
        const uint32_t k = in.get<uint32_t>();
        if (k >= items.size() || owner[k] != r) throw std::logic_error("MPI exchange: a rank sent a segment it does not own");
        decode(in, attributes, items[k]);
      }
    }
    std::vector<uint8_t>().swap(gathered[r]);
  }
}

}  // namespace

std::vector<uint32_t> ceiling_owners(std::span<const uint64_t> work, uint32_t ranks) {
  std::vector<uint32_t> owner(work.size(), 0);
  if (ranks <= 1) return owner;
  std::vector<uint32_t> order(work.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return work[a] > work[b]; });
  std::vector<uint64_t> load(ranks, 0);
  for (uint32_t k : order) {
    const uint32_t r = static_cast<uint32_t>(std::min_element(load.begin(), load.end()) - load.begin());  // the first of the least loaded
    owner[k] = r;
    load[r] += std::max<uint64_t>(1, work[k]);
  }
  return owner;
}

void share_results(Ranks& ranks, std::span<const uint32_t> owner, std::vector<CeilingResult>& results, const std::vector<storage::AttributeInfo>& attributes) {
  share(ranks, owner, results, attributes);
  // the variants to rank 0 alone, the one that writes them: the other ranks neither receive
  // them nor keep their own (rank 0 keeps its own where they are and sends nothing)
  const uint32_t me = static_cast<uint32_t>(ranks.rank());
  ByteWriter out;
  for (uint32_t k = 0; k < results.size() && me != 0; ++k)
    if (owner[k] == me && !results[k].variants.empty()) {
      out.put<uint32_t>(k);
      encode_variants(results[k].variants, out);
      std::vector<VariantMesh>().swap(results[k].variants);
    }
  std::vector<std::vector<uint8_t>> gathered = ranks.gather(out.bytes(), 0);
  for (uint32_t r = 1; r < gathered.size(); ++r) {
    ByteReader in(gathered[r]);
    while (!in.done()) {
      const uint32_t k = in.get<uint32_t>();
      if (k >= results.size() || owner[k] != r) throw std::logic_error("MPI exchange: a rank sent variants of a segment it does not own");
      decode_variants(in, results[k].variants);
    }
    std::vector<uint8_t>().swap(gathered[r]);
  }
}

void share_traces(Ranks& ranks, std::span<const uint32_t> owner, std::vector<CeilingTrace>& traces) { share(ranks, owner, traces, {}); }

}  // namespace tetrascope::lod::mt
