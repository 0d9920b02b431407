// CPU parts of rendering: the scene mesh, colormaps, pre-integration, marching tetrahedra,
// image comparison and encoding.
#include <png.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

namespace {
constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
}

namespace {
// values of an attribute per vertex (vector magnitude for vectors), non-finite as 0
std::vector<float> values_of(const storage::TetMesh& mesh, const storage::Attribute& a) {
  std::vector<float> out(mesh.vertex_count(), 0.0f);
  const uint32_t c = a.info.components;
  for (size_t v = 0; v < out.size(); ++v) {
    double m = 0;
    for (uint32_t k = 0; k < c; ++k) m += double(a.values[v * c + k]) * a.values[v * c + k];
    const double value = c == 1 ? double(a.values[v]) : std::sqrt(m);
    out[v] = std::isfinite(value) ? static_cast<float>(value) : 0.0f;
  }
  return out;
}
}  // namespace

SceneMesh SceneMesh::from(const storage::TetMesh& mesh, const std::string& attribute, const std::string& second_attribute) {
  SceneMesh s;
  const size_t n = mesh.vertex_count();
  s.xyz.resize(3 * n);
  for (size_t v = 0; v < n; ++v) {
    s.xyz[3 * v] = mesh.x[v];
    s.xyz[3 * v + 1] = mesh.y[v];
    s.xyz[3 * v + 2] = mesh.z[v];
  }
  s.tets = mesh.tets;
  s.bounds = storage::compute_bounds(mesh);
  s.diagonal = std::max(1e-30, std::sqrt(std::pow(s.bounds.max[0] - s.bounds.min[0], 2) + std::pow(s.bounds.max[1] - s.bounds.min[1], 2) +
                                         std::pow(s.bounds.max[2] - s.bounds.min[2], 2)));
  const storage::Attribute* a = nullptr;
  if (!attribute.empty()) {
    a = mesh.find_attribute(attribute);
    if (!a) {
      std::string names;
      for (const auto& b : mesh.attributes) names += (names.empty() ? "" : ", ") + b.info.name;
      throw std::invalid_argument("no attribute '" + attribute + "' (the mesh has: " + (names.empty() ? "none" : names) + ")");
    }
  } else if (!mesh.attributes.empty()) {
    a = &mesh.attributes.front();
  }
  s.value.assign(n, 0.0f);
  if (a) {
    s.attribute = a->info.name;
    s.value = values_of(mesh, *a);
  }
  if (n) {
    auto [lo, hi] = std::minmax_element(s.value.begin(), s.value.end());
    s.value_min = *lo;
    s.value_max = *hi;
  }
  if (!second_attribute.empty()) {
    const storage::Attribute* b = mesh.find_attribute(second_attribute);
    if (!b) throw std::invalid_argument("no attribute '" + second_attribute + "' to colour by");
    s.second = values_of(mesh, *b);
    s.second_attribute = second_attribute;
    if (n) {
      auto [lo, hi] = std::minmax_element(s.second.begin(), s.second.end());
      s.second_min = *lo;
      s.second_max = *hi;
    }
  }
  // boundary faces, and the longest edge (the pre-integration table's length range)
  std::vector<std::pair<std::array<uint32_t, 3>, std::array<uint32_t, 3>>> faces;
  faces.reserve(s.tets.size());
  double longest = 0;
  for (size_t t = 0; t < s.tets.size() / 4; ++t) {
    const uint32_t* tet = &s.tets[4 * t];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k) d2 += std::pow(double(s.xyz[3 * size_t{tet[i]} + k]) - s.xyz[3 * size_t{tet[j]} + k], 2);
        longest = std::max(longest, d2);
      }
    for (const auto& f : kFace) {
      std::array<uint32_t, 3> face{tet[f[0]], tet[f[1]], tet[f[2]]}, key = face;
      std::sort(key.begin(), key.end());
      faces.push_back({key, face});
    }
  }
  s.max_edge = std::sqrt(longest);
  std::sort(faces.begin(), faces.end());
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].first == faces[i].first) ++j;
    if (j - i == 1) s.boundary.push_back(faces[i].second);
    i = j;
  }
  return s;
}

bool known_colormap(const std::string& name) { return name == "viridis" || name == "plasma" || name == "cool-warm" || name == "grayscale"; }

std::array<float, 3> colormap(const std::string& name, double t) {
  t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
  auto poly = [&](const double c[7][3]) {
    std::array<float, 3> out{};
    for (int k = 0; k < 3; ++k) {
      double v = c[6][k];
      for (int i = 5; i >= 0; --i) v = c[i][k] + t * v;
      out[k] = static_cast<float>(std::clamp(v, 0.0, 1.0));
    }
    return out;
  };
  if (name == "plasma") {
    static const double c[7][3] = {{0.05873234392399702, 0.02333670892565664, 0.5433401826748754}, {2.176514634195958, 0.2383834171260182, 0.7539604599784036},
                                   {-2.689460476458034, -7.455851135738909, 3.110799939717086},   {6.130348345893603, 42.3461881477227, -28.51885465332158},
                                   {-11.10743619062271, -82.66631109428045, 60.13984767418263},   {10.02306557647065, 71.41361770095349, -54.07218655560067},
                                   {-3.658713842777788, -22.93153465461149, 18.19190778539828}};
    return poly(c);
  }
  if (name == "cool-warm") {  // Moreland's diverging map through its published control colours
    static const double p[5][4] = {{0.0, 0.230, 0.299, 0.754}, {0.25, 0.552, 0.690, 0.996}, {0.5, 0.865, 0.865, 0.865}, {0.75, 0.956, 0.604, 0.486}, {1.0, 0.706, 0.016, 0.150}};
    int i = std::min(3, static_cast<int>(t * 4));
    const double u = (t - p[i][0]) / (p[i + 1][0] - p[i][0]);
    return {static_cast<float>(p[i][1] + u * (p[i + 1][1] - p[i][1])), static_cast<float>(p[i][2] + u * (p[i + 1][2] - p[i][2])),
            static_cast<float>(p[i][3] + u * (p[i + 1][3] - p[i][3]))};
  }
  if (name == "grayscale") return {static_cast<float>(t), static_cast<float>(t), static_cast<float>(t)};
  static const double c[7][3] = {{0.2777273272234177, 0.005407344544966578, 0.3340998053353061}, {0.1050930431085774, 1.404613529898575, 1.384590162594685},
                                 {-0.3308618287255563, 0.214847559468213, 0.09509516302823659},  {-4.634230498983486, -5.799100973351585, -19.33244095627987},
                                 {6.228269936347081, 14.17993336680509, 56.69055260068105},      {4.776384997670288, -13.74514537774601, -65.35303263337234},
                                 {-5.435455855934631, 4.645852612178535, 26.3124352495832}};
  return poly(c);  // viridis
}

namespace {
// colour and extinction (per unit length) at normalised value t
struct Classified {
  std::array<float, 3> color;
  double tau;
};
Classified classify(const lod::TransferFunction& tf, double lo, double hi, double unit_distance, double t) {
  const double value = lo + std::clamp(t, 0.0, 1.0) * (hi - lo);
  const double alpha = std::clamp(tf.alpha(value), 0.0, 0.999999);
  return {tf.colors.empty() ? colormap(tf.colormap, t) : tf.user_color(value), -std::log(1 - alpha) / unit_distance};
}
}  // namespace

std::array<double, 4> integrate_segment(const lod::TransferFunction& tf, double lo, double hi, double unit_distance, double front, double back,
                                        double length) {
  // steps follow the change of value along the segment (a constant value integrates exactly
  // in any number of steps): at most 1/1024 of the range a step
  const int steps = std::clamp(static_cast<int>(std::ceil(std::fabs(back - front) * 1024)), 4, 1024);
  double r = 0, g = 0, b = 0, a = 0;
  const double dt = length / steps;
  for (int k = 0; k < steps && a < 0.9999; ++k) {
    const double t = front + (back - front) * (k + 0.5) / steps;
    const Classified c = classify(tf, lo, hi, unit_distance, t);
    const double alpha = 1 - std::exp(-c.tau * dt);
    r += (1 - a) * alpha * c.color[0];
    g += (1 - a) * alpha * c.color[1];
    b += (1 - a) * alpha * c.color[2];
    a += (1 - a) * alpha;
  }
  return {r, g, b, a};
}

PreintegrationTable preintegrate(const lod::TransferFunction& tf, double lo, double hi, double unit_distance, double max_length, uint32_t n,
                                 uint32_t lengths) {
  PreintegrationTable table;
  table.n = n;
  table.lengths = lengths;
  table.max_length = max_length;
  table.rgba.resize(size_t{n} * n * lengths * 4);
  // classified values on a fine grid, so the inner loop needs one exp a step
  const int fine = 1024;
  std::vector<Classified> grid(fine + 1);
  for (int i = 0; i <= fine; ++i) grid[i] = classify(tf, lo, hi, unit_distance, double(i) / fine);
  auto at = [&](double t) -> const Classified& { return grid[static_cast<size_t>(std::lround(std::clamp(t, 0.0, 1.0) * fine))]; };
  auto work = [&](uint32_t first_length, uint32_t step) {
    const int steps = 24;
    for (uint32_t m = first_length; m < lengths; m += step) {
      const double length = max_length * m / std::max(1u, lengths - 1);
      const double dt = length / steps;
      for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
          const double front = double(i) / (n - 1), back = double(j) / (n - 1);
          double r = 0, g = 0, b = 0, a = 0;
          for (int k = 0; k < steps; ++k) {
            const Classified& c = at(front + (back - front) * (k + 0.5) / steps);
            const double alpha = 1 - std::exp(-c.tau * dt);
            const double w = (1 - a) * alpha;
            r += w * c.color[0];
            g += w * c.color[1];
            b += w * c.color[2];
            a += w;
          }
          float* out = &table.rgba[((size_t{m} * n + j) * n + i) * 4];
          out[0] = static_cast<float>(r);
          out[1] = static_cast<float>(g);
          out[2] = static_cast<float>(b);
          out[3] = static_cast<float>(a);
        }
    }
  };
  std::thread other(work, 1, 2);
  work(0, 2);
  other.join();
  return table;
}

std::vector<float> marching_tets(const SceneMesh& mesh, double isovalue, std::vector<float>* second) {
  std::vector<float> out;
  if (second && mesh.second.size() != mesh.value.size()) throw std::invalid_argument("the scene has no second attribute");
  // a corner: position and, in the fourth slot, the second attribute
  auto point = [&](uint32_t a, uint32_t b) {
    const double va = mesh.value[a], vb = mesh.value[b];
    const double u = vb != va ? std::clamp((isovalue - va) / (vb - va), 0.0, 1.0) : 0.5;
    std::array<float, 4> p{};
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(mesh.xyz[3 * size_t{a} + k] + u * (mesh.xyz[3 * size_t{b} + k] - mesh.xyz[3 * size_t{a} + k]));
    if (second) p[3] = static_cast<float>(mesh.second[a] + u * (mesh.second[b] - mesh.second[a]));
    return p;
  };
  for (size_t t = 0; t < mesh.tets.size() / 4; ++t) {
    const uint32_t* tet = &mesh.tets[4 * t];
    uint32_t above[4], below[4];
    int na = 0, nb = 0;
    for (int k = 0; k < 4; ++k) (mesh.value[tet[k]] >= isovalue ? above[na++] : below[nb++]) = tet[k];
    if (na == 0 || nb == 0) continue;
    std::vector<std::array<float, 4>> poly;
    if (na == 1) {
      for (int k = 0; k < 3; ++k) poly.push_back(point(above[0], below[k]));
    } else if (nb == 1) {
      for (int k = 0; k < 3; ++k) poly.push_back(point(below[0], above[k]));
    } else {  // a quad, in cyclic order
      poly = {point(above[0], below[0]), point(above[0], below[1]), point(above[1], below[1]), point(above[1], below[0])};
    }
    // orient towards increasing values: the direction from a below vertex to an above one
    double up[3];
    for (int k = 0; k < 3; ++k) up[k] = mesh.xyz[3 * size_t{above[0]} + k] - mesh.xyz[3 * size_t{below[0]} + k];
    auto emit = [&](const std::array<float, 4>& a, const std::array<float, 4>& b, const std::array<float, 4>& c) {
      const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]}, e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
      const double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      const bool flip = nrm[0] * up[0] + nrm[1] * up[1] + nrm[2] * up[2] < 0;
      const std::array<float, 4>* corners[3] = {&a, flip ? &c : &b, flip ? &b : &c};
      for (auto* p : corners) {
        out.insert(out.end(), p->begin(), p->begin() + 3);
        if (second) second->push_back((*p)[3]);
      }
    };
    emit(poly[0], poly[1], poly[2]);
    if (poly.size() == 4) emit(poly[0], poly[2], poly[3]);
  }
  return out;
}

double psnr(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height) throw std::invalid_argument("psnr: images differ in size");
  double sum = 0;
  const size_t pixels = size_t{a.width} * a.height;
  for (size_t i = 0; i < pixels; ++i)
    for (int k = 0; k < 3; ++k) {
      const double d = double(a.rgba[4 * i + k]) - b.rgba[4 * i + k];
      sum += d * d;
    }
  const double mse = sum / (3.0 * std::max<size_t>(pixels, 1));
  return mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99.0;
}

std::vector<uint8_t> encode_jpeg(const Image& image, int quality) {
  if (quality < 1 || quality > 100) throw std::invalid_argument("JPEG quality must be 1 to 100");
  tjhandle handle = tjInitCompress();
  if (!handle) throw RenderError("libjpeg-turbo: cannot create a compressor");
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  const int rc = tjCompress2(handle, image.rgba.data(), static_cast<int>(image.width), 0, static_cast<int>(image.height), TJPF_RGBA, &buffer, &size,
                             TJSAMP_420, quality, TJFLAG_FASTDCT);
  std::vector<uint8_t> out;
  if (rc == 0) out.assign(buffer, buffer + size);
  const std::string error = rc == 0 ? "" : tjGetErrorStr2(handle);
  tjFree(buffer);
  tjDestroy(handle);
  if (rc != 0) throw RenderError("JPEG encoding failed: " + error);
  return out;
}

std::vector<uint8_t> encode_png(const Image& image) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = image.width;
  png.height = image.height;
  png.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.rgba.data(), 0, nullptr)) throw RenderError(std::string("PNG encoding failed: ") + png.message);
  std::vector<uint8_t> out(size);
  if (!png_image_write_to_memory(&png, out.data(), &size, 0, image.rgba.data(), 0, nullptr)) throw RenderError(std::string("PNG encoding failed: ") + png.message);
  out.resize(size);
  return out;
}

void write_image(const std::string& path, const Image& image, int quality) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::vector<uint8_t> bytes;
  if (ext == ".png") bytes = encode_png(image);
  else if (ext == ".jpg" || ext == ".jpeg") bytes = encode_jpeg(image, quality);
  else throw std::invalid_argument(path + ": the output must end in .png, .jpg or .jpeg");
  const std::string temp = path + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      std::remove(temp.c_str());
      throw std::runtime_error(path + ": cannot write (disk full or no permission?)");
    }
  }
  std::filesystem::rename(temp, path);
}

}  // namespace tetrascope::renderer
