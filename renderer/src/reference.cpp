// The CPU reference renderer: for every pixel, the exact segments its ray cuts through the
// tets, sorted by depth and composed front to back with integrate_segment - the same
// transfer function integrated finely, with no table and no per-tet sort. With isosurfaces
// (settings.iso, coloured by value), a segment that crosses isovalues is split there and the
// lit surface composed between its parts, at the isosurface opacity - what the GL renderer
// does inside the volume (and, at opacity 1, what its opaque isosurfaces show).
#include <algorithm>
#include <cmath>

#include "camera_math.h"
#include "slice_hits.h"
#include "tet_field.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

Image reference_render(const SceneMesh& mesh, const RenderSettings& settings) {
  const uint32_t W = settings.width, H = settings.height;
  const Frame frame = camera_frame(settings.camera, W, H);
  const auto [lo, hi] = colour_range(mesh, settings.tf);
  const double unit = settings.unit_distance > 0 ? settings.unit_distance : mesh.diagonal / 100;
  struct Segment {
    float t_in, t_out, s_in, s_out, light;
  };
  std::vector<double> isos;  // over [lo, hi], ascending, distinct
  if (settings.iso && !settings.use_iso_color_attribute)
    for (double v : settings.isovalues) isos.push_back(static_cast<float>((v - lo) / (hi - lo)));  // as the renderer's float uniforms
  std::sort(isos.begin(), isos.end());
  isos.erase(std::unique(isos.begin(), isos.end()), isos.end());
  const double iso_opacity = std::clamp(settings.iso_opacity, 0.0, 1.0);
  std::vector<std::vector<Segment>> pixels(size_t{W} * H);
  for (size_t t = 0; t < mesh.tets.size() / 4; ++t) {
    const uint32_t* tet = &mesh.tets[4 * t];
    Vec3 p[4];
    double s[4];
    for (int k = 0; k < 4; ++k) {
      p[k] = {mesh.xyz[3 * size_t{tet[k]}], mesh.xyz[3 * size_t{tet[k]} + 1], mesh.xyz[3 * size_t{tet[k]} + 2]};
      s[k] = (mesh.value[tet[k]] - lo) / (hi - lo);
    }
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
    // pixel box of the projection
    const PixelBox box = pixel_box(frame, p);
    for (int y = box.y0; y <= box.y1; ++y)
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
        const double gn = length(g);
        const float light = static_cast<float>(0.25 + 0.75 * (gn > 0 ? std::fabs(dot(g, dir)) / (gn * length(dir)) : 1.0));
        const Vec3 a{o[0] + t_in * dir[0], o[1] + t_in * dir[1], o[2] + t_in * dir[2]}, b{o[0] + t_out * dir[0], o[1] + t_out * dir[1], o[2] + t_out * dir[2]};
        pixels[size_t{static_cast<uint32_t>(y)} * W + static_cast<uint32_t>(x)].push_back(
            {static_cast<float>(t_in), static_cast<float>(t_out), static_cast<float>(dot(g, a) + c0), static_cast<float>(dot(g, b) + c0), light});
      }
  }
  // slices are opaque: rays end at the nearest one, which shows behind the volume before it
  const SliceHits slices = slice_hits(mesh, settings, lo, hi);
  Image image{W, H, std::vector<uint8_t>(size_t{W} * H * 4), std::vector<float>(size_t{W} * H * 3)};
  for (size_t i = 0; i < pixels.size(); ++i) {
    auto& list = pixels[i];
    std::sort(list.begin(), list.end(), [](const Segment& a, const Segment& b) { return a.t_in < b.t_in; });
    double r = 0, g = 0, b = 0, a = 0;
    const float stop = slices.distance[i];
    auto over = [&](const std::array<double, 4>& c) {
      r += (1 - a) * c[0];
      g += (1 - a) * c[1];
      b += (1 - a) * c[2];
      a += (1 - a) * c[3];
    };
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
        over(integrate_segment(settings.tf, lo, hi, unit, s0, iv, ti - t0));
        const double value = lo + std::clamp(iv, 0.0, 1.0) * (hi - lo);
        const auto base = settings.tf.colors.empty() ? colormap(settings.tf.colormap, std::clamp(iv, 0.0, 1.0)) : settings.tf.user_color(value);
        over({base[0] * seg.light * iso_opacity, base[1] * seg.light * iso_opacity, base[2] * seg.light * iso_opacity, iso_opacity});
        s0 = iv;
        t0 = ti;
      }
      over(integrate_segment(settings.tf, lo, hi, unit, s0, seg.s_out, length_in - t0));
    }
    const bool hit = std::isfinite(stop);
    const std::array<float, 3> behind = hit ? slices.rgb[i] : settings.background;
    const double out[3] = {r + (1 - a) * behind[0], g + (1 - a) * behind[1], b + (1 - a) * behind[2]};
    for (int k = 0; k < 3; ++k) {
      const double c = std::clamp(out[k], 0.0, 1.0);
      image.rgba[4 * i + k] = static_cast<uint8_t>(std::lround(c * 255));
      image.rgb[3 * i + k] = static_cast<float>(c);
    }
    image.rgba[4 * i + 3] = 255;
    std::vector<Segment>().swap(list);
  }
  return image;
}

}  // namespace tetrascope::renderer
