#include "tetrascope/storage/vtk_writer.h"

#include <bit>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace tetrascope::storage {
namespace {

class BigEndianFile {
 public:
  explicit BigEndianFile(const std::filesystem::path& path) : file_(std::fopen(path.c_str(), "wb")) {
    if (!file_) throw std::runtime_error(path.string() + ": cannot write");
  }
  ~BigEndianFile() {
    if (file_) std::fclose(file_);
  }
  void text(const std::string& s) { put(s.data(), s.size()); }
  template <typename T>
  void values(const T* v, size_t n) {
    std::vector<T> buffer(std::min<size_t>(n, 1 << 16));
    for (size_t done = 0; done < n; done += buffer.size()) {
      size_t m = std::min(buffer.size(), n - done);
      for (size_t i = 0; i < m; ++i) buffer[i] = swap(v[done + i]);
      put(buffer.data(), m * sizeof(T));
    }
  }
  void close() {
    if (std::fflush(file_) != 0 || std::ferror(file_) || std::fclose(file_) != 0) {
      file_ = nullptr;
      throw std::runtime_error("write failed");
    }
    file_ = nullptr;
  }

 private:
  template <typename T>
  static T swap(T v) {
    if constexpr (std::endian::native == std::endian::big) return v;
    uint32_t u;
    std::memcpy(&u, &v, 4);
    u = __builtin_bswap32(u);
    std::memcpy(&v, &u, 4);
    return v;
  }
  void put(const void* p, size_t n) {
    if (std::fwrite(p, 1, n, file_) != n) throw std::runtime_error("write failed");
  }
  std::FILE* file_;
};

std::string safe_name(const std::string& name) {
  std::string s;
  for (char c : name) s += (c == ' ' || c == '\t' || c == '\n') ? '_' : c;
  return s.empty() ? "field" : s;
}

}  // namespace

void write_vtk(const std::filesystem::path& path, const TetMesh& mesh, const std::string& title) {
  std::filesystem::path temp = path;
  temp += ".tmp";
  try {
    BigEndianFile out(temp);
    const size_t n = mesh.vertex_count(), m = mesh.tet_count();
    std::string head = "# vtk DataFile Version 3.0\n" + title.substr(0, 250) + "\nBINARY\nDATASET UNSTRUCTURED_GRID\n";
    out.text(head + "POINTS " + std::to_string(n) + " float\n");
    std::vector<float> xyz(3 * n);
    for (size_t i = 0; i < n; ++i) {
      xyz[3 * i] = mesh.x[i];
      xyz[3 * i + 1] = mesh.y[i];
      xyz[3 * i + 2] = mesh.z[i];
    }
    out.values(xyz.data(), xyz.size());
    out.text("\nCELLS " + std::to_string(m) + " " + std::to_string(5 * m) + "\n");
    std::vector<int32_t> cells(5 * std::min<size_t>(m, 1 << 16));
    for (size_t done = 0; done < m; done += cells.size() / 5) {
      size_t k = std::min(cells.size() / 5, m - done);
      for (size_t t = 0; t < k; ++t) {
        cells[5 * t] = 4;
        for (int j = 0; j < 4; ++j) cells[5 * t + 1 + j] = static_cast<int32_t>(mesh.tets[4 * (done + t) + j]);
      }
      out.values(cells.data(), 5 * k);
    }
    out.text("\nCELL_TYPES " + std::to_string(m) + "\n");
    std::vector<int32_t> types(std::min<size_t>(m, 1 << 16), 10);
    for (size_t done = 0; done < m; done += types.size()) out.values(types.data(), std::min(types.size(), m - done));
    out.text("\n");
    if (!mesh.attributes.empty()) {
      out.text("POINT_DATA " + std::to_string(n) + "\n");
      std::vector<const Attribute*> other;
      for (const Attribute& a : mesh.attributes) {
        if (a.info.components == 1) {
          out.text("SCALARS " + safe_name(a.info.name) + " float 1\nLOOKUP_TABLE default\n");
        } else if (a.info.components == 3) {
          out.text("VECTORS " + safe_name(a.info.name) + " float\n");
        } else if (a.info.kind == AttributeKind::kTensor && a.info.components == 6) {
          out.text("TENSORS6 " + safe_name(a.info.name) + " float\n");  // read back as a tensor
        } else {
          other.push_back(&a);
          continue;
        }
        out.values(a.values.data(), a.values.size());
        out.text("\n");
      }
      if (!other.empty()) {
        out.text("FIELD FieldData " + std::to_string(other.size()) + "\n");
        for (const Attribute* a : other) {
          out.text(safe_name(a->info.name) + " " + std::to_string(a->info.components) + " " + std::to_string(n) + " float\n");
          out.values(a->values.data(), a->values.size());
          out.text("\n");
        }
      }
    }
    out.close();
    std::filesystem::rename(temp, path);
  } catch (const std::exception& e) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

}  // namespace tetrascope::storage
