// Image encoding (libjpeg-turbo, libpng) and writing an image file atomically. The only
// place those libraries are used.
#include <png.h>
#include <turbojpeg.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

Image read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) throw std::invalid_argument(path + ": not a PNG image (" + png.message + ")");
  png.format = PNG_FORMAT_RGBA;
  if (png.width < 1 || png.height < 1 || png.width > kMaxImageSide || png.height > kMaxImageSide) {
    png_image_free(&png);
    throw std::invalid_argument(path + ": image sides must be 1.." + std::to_string(kMaxImageSide));
  }
  Image image{png.width, png.height, std::vector<uint8_t>(PNG_IMAGE_SIZE(png)), {}};
  if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr)) throw std::invalid_argument(path + ": unreadable PNG (" + png.message + ")");
  return image;
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

namespace {
// bytes to a temporary name of this process and call, renamed to path when complete: two
// writers of one path never share a half-written file
void write_whole(const std::string& path, const std::vector<uint8_t>& bytes) {
  static std::atomic<uint64_t> calls{0};
  const std::string temp = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(calls++);
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
}  // namespace

void write_image(const std::string& path, const Image& image, int quality) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::vector<uint8_t> bytes;
  if (ext == ".png") bytes = encode_png(image);
  else if (ext == ".jpg" || ext == ".jpeg") bytes = encode_jpeg(image, quality);
  else throw std::invalid_argument(path + ": the output must end in .png, .jpg or .jpeg");
  write_whole(path, bytes);
}

void write_pfm(const std::string& path, const Image& image) {
  const size_t row = size_t{image.width} * 3;
  if (image.rgb.size() != row * image.height) throw std::invalid_argument(path + ": the image has no float colours (only the reference renderer keeps them)");
  const std::string header = "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";  // -1: little-endian
  std::vector<uint8_t> bytes(header.begin(), header.end());
  bytes.reserve(header.size() + 4 * row * image.height);
  for (uint32_t y = image.height; y-- > 0;) {  // PFM rows go bottom to top
    const auto* first = reinterpret_cast<const uint8_t*>(&image.rgb[y * row]);
    for (size_t b = 0; b < 4 * row; b += 4) {  // as little-endian bytes whatever the host
      uint32_t v;
      std::memcpy(&v, first + b, 4);
      for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<uint8_t>(v >> (8 * k)));
    }
  }
  write_whole(path, bytes);
}

}  // namespace tetrascope::renderer
