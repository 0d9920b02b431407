// The CPU reference renderer: for every pixel, the exact segments its ray cuts through the
// tets, sorted by depth and composed front to back with integrate_segment - the same
// transfer function integrated finely, with no table and no per-tet sort. With isosurfaces
// (settings.iso, coloured by value), a segment that crosses isovalues is split there and the
// lit surface composed between its parts, at the isosurface opacity - what the GL renderer
// does inside the volume (and, at opacity 1, what its opaque isosurfaces show).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "camera_math.h"
#include "slice_hits.h"
#include "tet_field.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

namespace {

struct Segment {
  float t_in, t_out, s_in, s_out, light;
};

// What every band needs: the frame, the colour range, the isovalues over [0, 1] and the slices.
struct ReferenceFrame {
  const SceneMesh& mesh;
  const RenderSettings& settings;
  Frame frame;
  double lo, hi, unit, iso_opacity;
  std::vector<double> isos;  // over [lo, hi], ascending, distinct
  SliceHits slices;
};

// The segments the rays of rows [y0, y1) cut through the tets, per pixel of those rows.
void gather_band(const ReferenceFrame& rf, int y0, int y1, std::vector<std::vector<Segment>>* pixels) {
  const SceneMesh& mesh = rf.mesh;
  const Frame& frame = rf.frame;
  const uint32_t W = rf.settings.width;
  for (size_t t = 0; t < mesh.tets.size() / 4; ++t) {
    const uint32_t* tet = &mesh.tets[4 * t];
    Vec3 p[4];
    double s[4];
    for (int k = 0; k < 4; ++k) {
      p[k] = {mesh.xyz[3 * size_t{tet[k]}], mesh.xyz[3 * size_t{tet[k]} + 1], mesh.xyz[3 * size_t{tet[k]} + 2]};
      s[k] = (mesh.value[tet[k]] - rf.lo) / (rf.hi - rf.lo);
    }
    const PixelBox box = pixel_box(frame, p);
    if (box.y1 < y0 || box.y0 >= y1 || box.x1 < box.x0) continue;
    // planes (outward) and the linear field s(x) = g.x + c
    Vec3 n[4];
    double d[4];
    for (int f = 0; f < 4; ++f) {
      n[f] = cross(p[kTetFace[f][1]] - p[kTetFace[f][0]], p[kTetFace[f][2]] - p[kTetFace[f][0]]);
      d[f] = -dot(n[f], p[kTetFace[f][0]]);
    }
    Vec3 g;
    double c0;
    if (!linear_field(p, s, &g, &c0)) continue;
    const double gn = length(g);
    for (int y = std::max(box.y0, y0); y <= std::min(box.y1, y1 - 1); ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        Vec3 o, dir;
        ray(frame, x, y, &o, &dir);
        double t_in = 0, t_out = 1e300;
        bool miss = false;
        for (int f = 0; f < 4 && !miss; ++f) {
          const double dn = dot(n[f], dir), num = -(dot(n[f], o) + d[f]);
          if (dn > 0) t_out = std::min(t_out, num / dn);
          else if (dn < 0) t_in = std::max(t_in, num / dn);
          else if (num < 0) miss = true;  // parallel and outside
        }
        if (miss || !(t_in < t_out)) continue;
        const float light = static_cast<float>(0.25 + 0.75 * (gn > 0 ? std::fabs(dot(g, dir)) / (gn * length(dir)) : 1.0));
        const Vec3 a{o[0] + t_in * dir[0], o[1] + t_in * dir[1], o[2] + t_in * dir[2]}, b{o[0] + t_out * dir[0], o[1] + t_out * dir[1], o[2] + t_out * dir[2]};
        (*pixels)[size_t{static_cast<uint32_t>(y - y0)} * W + static_cast<uint32_t>(x)].push_back(
            {static_cast<float>(t_in), static_cast<float>(t_out), static_cast<float>(dot(g, a) + c0), static_cast<float>(dot(g, b) + c0), light});
      }
  }
}

// Pixel i's colour: its segments sorted by depth and composed front to back up to the slice.
std::array<double, 3> compose_pixel(const ReferenceFrame& rf, size_t i, std::vector<Segment>& list) {
  const RenderSettings& settings = rf.settings;
  const double lo = rf.lo, hi = rf.hi;
  std::sort(list.begin(), list.end(), [](const Segment& a, const Segment& b) { return a.t_in < b.t_in; });
  double r = 0, g = 0, b = 0, a = 0;
  const float stop = rf.slices.distance[i];
  auto over = [&](const std::array<double, 4>& c) {
    r += (1 - a) * c[0];
    g += (1 - a) * c[1];
    b += (1 - a) * c[2];
    a += (1 - a) * c[3];
  };
  const std::vector<double>& isos = rf.isos;
  for (Segment seg : list) {
    if (a > 0.9999 || seg.t_in >= stop) break;
    if (seg.t_out > stop) {  // the segment ends at the slice
      seg.s_out = seg.s_in + (seg.s_out - seg.s_in) * (stop - seg.t_in) / (seg.t_out - seg.t_in);
      seg.t_out = stop;
    }
    const double length_in = double(seg.t_out) - seg.t_in;
    double s0 = seg.s_in, t0 = 0;
    const bool rising = seg.s_out > seg.s_in;
    for (size_t k = 0; k < isos.size(); ++k) {
      const double iv = isos[rising ? k : isos.size() - 1 - k];
      if ((s0 < iv) == (seg.s_out < iv)) continue;
      const double ti = length_in * (iv - seg.s_in) / (double(seg.s_out) - seg.s_in);
      over(integrate_segment(settings.tf, lo, hi, rf.unit, s0, iv, ti - t0));
      const double value = lo + std::clamp(iv, 0.0, 1.0) * (hi - lo);
      const auto base = settings.tf.colors.empty() ? colormap(settings.tf.colormap, std::clamp(iv, 0.0, 1.0)) : settings.tf.user_color(value);
      const double op = rf.iso_opacity;
      over({base[0] * seg.light * op, base[1] * seg.light * op, base[2] * seg.light * op, op});
      s0 = iv;
      t0 = ti;
    }
    over(integrate_segment(settings.tf, lo, hi, rf.unit, s0, seg.s_out, length_in - t0));
  }
  const bool hit = std::isfinite(stop);
  const std::array<float, 3> behind = hit ? rf.slices.rgb[i] : settings.background;
  return {r + (1 - a) * behind[0], g + (1 - a) * behind[1], b + (1 - a) * behind[2]};
}

}  // namespace

Image reference_render(const SceneMesh& mesh, const RenderSettings& settings) {
  const uint32_t W = settings.width, H = settings.height;
  const auto [lo, hi] = colour_range(mesh, settings.tf);
  ReferenceFrame rf{mesh, settings, camera_frame(settings.camera, W, H), lo, hi,
                    settings.unit_distance > 0 ? settings.unit_distance : mesh.diagonal / 100, std::clamp(settings.iso_opacity, 0.0, 1.0), {}, {}};
  if (settings.iso && !settings.use_iso_color_attribute)
    for (double v : settings.isovalues) rf.isos.push_back(static_cast<float>((v - lo) / (hi - lo)));  // as the renderer's float uniforms
  std::sort(rf.isos.begin(), rf.isos.end());
  rf.isos.erase(std::unique(rf.isos.begin(), rf.isos.end()), rf.isos.end());
  // slices are opaque: rays end at the nearest one, which shows behind the volume before it
  rf.slices = slice_hits(mesh, settings, lo, hi);
  Image image{W, H, std::vector<uint8_t>(size_t{W} * H * 4), std::vector<float>(size_t{W} * H * 3)};
  // Bands of rows, taken by the threads in turn: each gathers and composes its own pixels,
  // so memory holds one band's segments per thread and the image does not depend on the threads.
  const int band_rows = static_cast<int>(std::clamp<uint32_t>(H / 16, 1, 64));
  const int bands = (static_cast<int>(H) + band_rows - 1) / band_rows;
  std::atomic<int> next{0};
  auto work = [&] {
    std::vector<std::vector<Segment>> pixels;
    for (int band; (band = next.fetch_add(1)) < bands;) {
      const int y0 = band * band_rows, y1 = std::min(static_cast<int>(H), y0 + band_rows);
      pixels.assign(size_t{W} * static_cast<size_t>(y1 - y0), {});
      gather_band(rf, y0, y1, &pixels);
      for (size_t j = 0; j < pixels.size(); ++j) {
        const size_t i = size_t{W} * static_cast<size_t>(y0) + j;
        const std::array<double, 3> out = compose_pixel(rf, i, pixels[j]);
        for (int k = 0; k < 3; ++k) {
          const double c = std::clamp(out[k], 0.0, 1.0);
          image.rgba[4 * i + k] = static_cast<uint8_t>(std::lround(c * 255));
          image.rgb[3 * i + k] = static_cast<float>(c);
        }
        image.rgba[4 * i + 3] = 255;
      }
    }
  };
  const unsigned threads = std::min<unsigned>(std::max(1u, std::thread::hardware_concurrency()), static_cast<unsigned>(bands));
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return image;
}

}  // namespace tetrascope::renderer
