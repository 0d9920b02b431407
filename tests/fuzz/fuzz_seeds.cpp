// Writes a seed corpus for each fuzz target: small valid files in every variant.
#include <algorithm>
#include <filesystem>
#include <iostream>

#include "fixture_writers.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/store.h"

using namespace tetrascope::testing;

namespace {
// Cell data for the VTK, VTU and Gmsh readers, and an OpenFOAM case of one tet
// (fuzz_openfoam: its files joined after "#NAME" lines).
void write_cell_data_seeds(const std::filesystem::path& out, const CellMesh& m) {
  // cell data: the cells' values averaged at the vertices
  CellMesh cells = m;
  tetrascope::storage::Attribute p{{"p", 1}, {1.0f, 2.0f, 3.0f}}, u{{"u", 3}, {1, 0, 0, 0, 1, 0, 0, 0, 1}};
  cells.cell_attributes = {p, u};
  write_vtk_legacy(out / "vtk/cell_data.vtk", cells, {.binary = true});
  write_vtu(out / "vtu/cell_data_zlib.vtu", cells, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 64});
  write_gmsh(out / "msh/cell_data41.msh", cells, {.version4 = true, .binary = false});
  // an OpenFOAM case of one tet (fuzz_openfoam: its files joined after "#NAME" lines)
  std::filesystem::create_directories(out / "openfoam");
  const std::string head = "FoamFile\n{\n    version 2.0;\n    format ascii;\n    class ";
  write_file(out / "openfoam" / "tet",
             "#points\n" + head + "vectorField;\n    object points;\n}\n4\n(\n(0 0 0)\n(1 0 0)\n(0 1 0)\n(0 0 1)\n)\n" +
             "#faces\n" + head + "faceList;\n    object faces;\n}\n4\n(\n3(0 2 1)\n3(0 1 3)\n3(0 3 2)\n3(1 2 3)\n)\n" +
             "#owner\n" + head + "labelList;\n    object owner;\n}\n4\n(\n0\n0\n0\n0\n)\n" +
             "#neighbour\n" + head + "labelList;\n    object neighbour;\n}\n0\n(\n)\n" +
             "#p\n" + head + "volScalarField;\n    object p;\n}\ndimensions [0 2 -2 0 0 0 0];\ninternalField nonuniform List<scalar> 1(2.5);\nboundaryField\n{\n}\n");
}

// Tensors: a 3x3 (VTK TENSORS, VTU and Gmsh 9 components) and a symmetric one (VTK TENSORS6,
// VTU 6 components), as point data.
void write_tensor_seeds(const std::filesystem::path& out, const CellMesh& m) {
  CellMesh tensors = m;
  tetrascope::storage::Attribute full{{"stress", 9, tetrascope::storage::AttributeKind::kTensor}, {}};
  tetrascope::storage::Attribute symmetric{{"diffusion", 6, tetrascope::storage::AttributeKind::kTensor}, {}};
  for (size_t i = 0; i < m.x.size(); ++i) {
    const float f = static_cast<float>(i);
    full.values.insert(full.values.end(), {f, 1, 0, 1.5f, -f, 2, 0, 2, 3});
    symmetric.values.insert(symmetric.values.end(), {2, 1, 0.5f + f, 0.25f, 0, 0});
  }
  tensors.attributes = {full, symmetric};
  write_vtk_legacy(out / "vtk/tensors.vtk", tensors, {.binary = true});
  write_vtk_legacy(out / "vtk/tensors_ascii.vtk", tensors, {.binary = false});
  write_vtu(out / "vtu/tensors.vtu", tensors, {.encoding = VtuEncoding::kAppendedRaw});
  tensors.attributes = {full};
  write_gmsh(out / "msh/tensors22.msh", tensors, {.version4 = false, .binary = false});
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_seeds OUTDIR\n";
    return 2;
  }
  std::filesystem::path out = argv[1];
  CellMesh m;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 3; ++i) {
        m.x.push_back(static_cast<float>(i));
        m.y.push_back(static_cast<float>(j));
        m.z.push_back(static_cast<float>(k));
      }
  m.add_cell(12, {0, 1, 4, 3, 6, 7, 10, 9});
  m.add_cell(10, {1, 2, 5, 8});
  m.add_cell(10, {1, 5, 4, 10});
  tetrascope::storage::Attribute t{{"t", 1}, {}}, v{{"v", 3}, {}};
  for (size_t i = 0; i < m.x.size(); ++i) {
    t.values.push_back(static_cast<float>(i));
    v.values.insert(v.values.end(), {1.0f, 2.0f, static_cast<float>(i)});
  }
  m.attributes = {t, v};
  CellMesh tets = m;
  tets.types = {10, 10};
  tets.offsets = {0, 4, 8};
  tets.connectivity = {1, 2, 5, 8, 1, 5, 4, 10};
  for (const char* d : {"vtk", "vtu", "msh", "tetgen", "off"}) std::filesystem::create_directories(out / d);
  write_vtk_legacy(out / "vtk/ascii.vtk", m, {.binary = false});
  write_vtk_legacy(out / "vtk/binary.vtk", m, {.binary = true});
  write_vtk_legacy(out / "vtk/v51.vtk", m, {.binary = true, .version5 = true});
  write_vtk_legacy(out / "vtk/field.vtk", m, {.binary = false, .field = true});
  write_vtu(out / "vtu/ascii.vtu", m, {.encoding = VtuEncoding::kAscii});
  write_vtu(out / "vtu/base64.vtu", m, {.encoding = VtuEncoding::kInlineBase64});
  write_vtu(out / "vtu/base64_zlib.vtu", m, {.encoding = VtuEncoding::kInlineBase64, .zlib = true, .block_size = 64});
  write_vtu(out / "vtu/raw.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .header_uint64 = false});
  write_vtu(out / "vtu/raw_zlib.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 64});
  write_gmsh(out / "msh/a22.msh", m, {.version4 = false, .binary = false});
  write_gmsh(out / "msh/b22.msh", m, {.version4 = false, .binary = true});
  write_gmsh(out / "msh/a41.msh", m, {.version4 = true, .binary = false});
  write_gmsh(out / "msh/b41.msh", m, {.version4 = true, .binary = true});
  write_cell_data_seeds(out, m);
  write_tensor_seeds(out, m);
  write_off(out / "off/a.off", tets);
  write_tetgen(out / "tetgen/t", tets);
  write_file(out / "tetgen/pair", read_file(out / "tetgen/t.node") + "#ele\n" + read_file(out / "tetgen/t.ele"));
  std::filesystem::remove(out / "tetgen/t.node");
  std::filesystem::remove(out / "tetgen/t.ele");
  // the store loader: a small multiresolution store in every segment compression, its files
  // joined as fuzz_store expects
  std::filesystem::create_directories(out / "store");
  std::filesystem::create_directories(out / "segment_codec");
  const auto store = out / "store.tmp";
  for (auto compression : {tetrascope::storage::store::Compression::kNone, tetrascope::storage::store::Compression::kIndex16,
                           tetrascope::storage::store::Compression::kCutBorder}) {
    const std::string name = tetrascope::storage::compression_name(compression);
    std::filesystem::remove_all(store);
    tetrascope::lod::PreprocessOptions options;
    options.threads = 1;
    options.compression = compression;
    tetrascope::lod::preprocess(out / "off/a.off", store, options, nullptr);
    write_file(out / "store" / ("multires_" + name), read_file(store / "manifest.json") + "#segments.bin\n" + read_file(store / "segments.bin") +
                                                         "\n#dag.bin\n" + read_file(store / "dag.bin"));
    write_file(out / "store" / ("no_dag_" + name), read_file(store / "manifest.json") + "#segments.bin\n" + read_file(store / "segments.bin"));
    if (compression != tetrascope::storage::store::Compression::kCutBorder) continue;
    // fuzz_segment_codec: each segment's stream with its counts and link faces in front
    auto opened = tetrascope::storage::Store::open(store);
    for (uint32_t s = 0; s < opened->segment_count(); ++s) {
      const auto& r = opened->record(s);
      const std::string bytes = read_file(store / "segments.bin").substr(r.offset, r.bytes);
      const auto layout = tetrascope::storage::store::segment_layout(r.vertex_count, r.tet_count, r.link_count, opened->header().floats_per_vertex, compression);
      std::string seed;
      for (uint32_t v : {r.vertex_count, r.tet_count}) seed += {static_cast<char>(v & 0xFF), static_cast<char>(v >> 8 & 0xFF)};
      const auto mapped = opened->map_segment(s);
      const auto links = mapped->view().links;
      const size_t link_count = std::min<size_t>(links.size(), 255);
      seed += static_cast<char>(link_count);
      for (size_t k = 0; k < link_count; ++k) seed += {static_cast<char>(links[k].face & 0xFF), static_cast<char>(links[k].face >> 8 & 0xFF)};
      write_file(out / "segment_codec" / ("segment" + std::to_string(s)), seed + bytes.substr(layout.bytes));
    }
  }
  // with segment variants (variants.bin after dag.bin): a grid of 6^3 cubes, 5 tets each, with
  // a value, in segments small enough to make levels
  {
    constexpr int k = 6;
    std::string text;
    auto at = [](int i, int j, int l) { return (l * (k + 1) + j) * (k + 1) + i; };
    text += std::to_string((k + 1) * (k + 1) * (k + 1)) + " " + std::to_string(5 * k * k * k) + "\n";
    for (int l = 0; l <= k; ++l)
      for (int j = 0; j <= k; ++j)
        for (int i = 0; i <= k; ++i) text += std::to_string(i) + " " + std::to_string(j) + " " + std::to_string(l) + " " + std::to_string(i * j + l) + "\n";
    for (int l = 0; l < k; ++l)
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const int c[8] = {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l), at(i, j + 1, l), at(i, j, l + 1), at(i + 1, j, l + 1), at(i + 1, j + 1, l + 1), at(i, j + 1, l + 1)};
          const int odd[5][4] = {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6}, {3, 4, 6, 7}, {1, 3, 4, 6}}, even[5][4] = {{0, 1, 2, 5}, {0, 2, 3, 7}, {0, 4, 5, 7}, {2, 5, 6, 7}, {0, 2, 5, 7}};
          for (const auto& t : (i + j + l) % 2 ? odd : even)
            text += std::to_string(c[t[0]]) + " " + std::to_string(c[t[1]]) + " " + std::to_string(c[t[2]]) + " " + std::to_string(c[t[3]]) + "\n";
        }
    write_file(out / "grid.off", text);
  }
  std::filesystem::remove_all(store);
  tetrascope::lod::PreprocessOptions options;
  options.threads = 1;
  options.segment_tets = 256;
  options.base_tets = 100;
  options.variants = 2;
  tetrascope::lod::preprocess(out / "grid.off", store, options, nullptr);
  std::filesystem::remove(out / "grid.off");
  if (std::filesystem::exists(store / "variants.bin"))
    write_file(out / "store" / "multires_variants", read_file(store / "manifest.json") + "#segments.bin\n" + read_file(store / "segments.bin") + "\n#dag.bin\n" +
                                                          read_file(store / "dag.bin") + "\n#variants.bin\n" + read_file(store / "variants.bin"));
  std::filesystem::remove_all(store);
  return 0;
}
