#include "retimegs/media/image_io.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <jpeglib.h>
#include <png.h>
#include <zlib.h>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>

#include "other_codecs.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"

namespace retimegs::media {
namespace fs = std::filesystem;

namespace {

// The standard CRC-32 of PNG chunks (ISO 3309, polynomial 0xEDB88320), table-driven.
std::uint32_t crc32(const unsigned char* data, std::size_t size, std::uint32_t crc = 0) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

std::uint32_t big_endian32(const unsigned char* p);

// A damaged file is named precisely here first: every PNG chunk whole with a correct CRC up to
// IEND; a JPEG starting with SOI and holding an EOI marker. decode_png / decode_jpeg report the
// rest, silently.
void check_encoded(const std::vector<unsigned char>& b, const std::string& name) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() >= 8 && std::memcmp(b.data(), kPng, 8) == 0) {
    for (std::size_t at = 8;;) {
      if (b.size() - at < 12) fail("{}: truncated PNG (no IEND chunk)", name);
      const std::uint32_t length = big_endian32(&b[at]);
      if (length > b.size() - at - 12) fail("{}: truncated PNG (a chunk runs past the end)", name);
      const unsigned char* type = &b[at + 4];
      if (crc32(type, 4 + std::size_t(length)) != big_endian32(type + 4 + length))
        fail("{}: damaged PNG (CRC mismatch in a '{}' chunk at byte {})", name,
             std::string(reinterpret_cast<const char*>(type), 4), at);
      if (std::memcmp(type, "IEND", 4) == 0) return;
      at += 12 + std::size_t(length);
    }
  }
  if (b.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8) {
    for (std::size_t i = b.size(); i-- > 3;)
      if (b[i - 1] == 0xFF && b[i] == 0xD9) return;
    fail("{}: truncated JPEG (no end-of-image marker)", name);
  }
}

// PNG through libpng directly, with handlers that keep it silent: imdecode leaves libpng's
// default handlers in place, which print "libpng warning: iCCP: known incorrect sRGB profile"
// for a valid file and "libpng error: ..." before a failure, lines beside the command's own.
// Warnings are dropped (the image decodes as it would anyway); an error is kept for the Error.
struct PngSource {
  const std::vector<unsigned char>* bytes;
  std::size_t at = 0;
  char message[256] = {};
};

void png_on_error(png_structp png, png_const_charp message) {
  auto* source = static_cast<PngSource*>(png_get_error_ptr(png));
  std::snprintf(source->message, sizeof source->message, "%s", message);
  png_longjmp(png, 1);
}

void png_on_warning(png_structp, png_const_charp) {}

void png_read_bytes(png_structp png, png_bytep out, png_size_t size) {
  auto* source = static_cast<PngSource*>(png_get_io_ptr(png));
  if (size > source->bytes->size() - source->at) png_error(png, "the file ends early");
  std::memcpy(out, source->bytes->data() + source->at, size);
  source->at += size;
}

// OpenCV's limits on a decoded image (CV_IO_MAX_IMAGE_WIDTH / _HEIGHT / _PIXELS): a header
// cannot ask for more memory than imread would have given it.
constexpr png_uint_32 kMaxSide = 1u << 20;
constexpr std::uint64_t kMaxPixels = std::uint64_t(1) << 30;

// The pixels of the PNG in `source` into `image`, as imread(IMREAD_UNCHANGED) gives them: 8-bit
// (bit depths 1, 2, 4 widened to 8) or 16-bit; grey 1 channel, colour BGR, 4 channels BGRA when
// the file has alpha (grey + alpha becomes BGRA too) or a tRNS chunk on a colour / palette image.
// False with source.message set on a libpng error. `image` and `rows` live in the caller's frame:
// libpng's errors return here by longjmp, which must not cross a frame with objects to destroy.
bool read_png_pixels(png_structp png, png_infop info, PngSource& source, cv::Mat& image,
                     std::vector<png_bytep>& rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_read_fn(png, &source, png_read_bytes);
  png_set_user_limits(png, kMaxSide, kMaxSide);
  png_read_info(png, info);
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  png_get_IHDR(png, info, &width, &height, &bit_depth, &color_type, nullptr, nullptr, nullptr);
  if (std::uint64_t(width) * height > kMaxPixels) png_error(png, "the image is too large");
  int channels = 1;
  if (color_type == PNG_COLOR_TYPE_RGB || color_type == PNG_COLOR_TYPE_PALETTE)
    channels = png_get_valid(png, info, PNG_INFO_tRNS) ? 4 : 3;
  else if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA || color_type == PNG_COLOR_TYPE_RGB_ALPHA)
    channels = 4;
  if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  if (channels < 4)
    png_set_strip_alpha(png);
  else
    png_set_tRNS_to_alpha(png);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((color_type & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  if (color_type & PNG_COLOR_MASK_COLOR)
    png_set_bgr(png);
  else if (channels > 1)
    png_set_gray_to_rgb(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const int depth = bit_depth == 16 ? CV_16U : CV_8U;
  if (png_get_rowbytes(png, info) != std::size_t(width) * channels * (depth == CV_16U ? 2 : 1))
    png_error(png, "unexpected row size");
  image.create(int(height), int(width), CV_MAKETYPE(depth, channels));
  rows.resize(height);
  for (png_uint_32 y = 0; y < height; ++y) rows[y] = image.ptr(int(y));
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  return true;
}

cv::Mat decode_png(const std::vector<unsigned char>& bytes, const std::string& name) {
  PngSource source{&bytes};
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, png_on_error, png_on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    fail("{}: cannot decode PNG (out of memory)", name);
  }
  cv::Mat image;
  std::vector<png_bytep> rows;
  const bool ok = read_png_pixels(png, info, source, image, rows);
  png_destroy_read_struct(&png, &info, nullptr);
  if (!ok) fail("{}: cannot decode PNG ({})", name, source.message);
  return image;
}

// JPEG through libjpeg(-turbo) directly, for the same reason as PNG: imdecode's error manager
// prints libjpeg's warnings ("Corrupt JPEG data: 2 extraneous bytes before marker 0xd9") and
// errors on stderr. Here warnings and trace messages are dropped and an error returns by longjmp
// with its text kept for the Error.
struct JpegErrors {
  jpeg_error_mgr manager;  // first: libjpeg hands back a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

void jpeg_on_error(j_common_ptr info) {
  auto* errors = reinterpret_cast<JpegErrors*>(info->err);
  (*info->err->format_message)(info, errors->message);
  std::longjmp(errors->jump, 1);
}

void jpeg_on_message(j_common_ptr, int) {}
void jpeg_on_output(j_common_ptr) {}

enum class JpegResult { kDecoded, kFailed, kCmyk };

// The pixels as imread(IMREAD_UNCHANGED) gives them: grey (one component) as 1 channel, colour as
// BGR. Four-component (CMYK / YCCK) files are left to imdecode (kCmyk), which converts them.
// `image` lives in the caller's frame: libjpeg's errors return here by longjmp.
JpegResult read_jpeg_pixels(jpeg_decompress_struct& info, JpegErrors& errors,
                            const std::vector<unsigned char>& bytes, cv::Mat& image) {
  if (setjmp(errors.jump)) return JpegResult::kFailed;
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  if (info.num_components == 4) return JpegResult::kCmyk;
  if (info.image_width > kMaxSide || info.image_height > kMaxSide ||
      std::uint64_t(info.image_width) * info.image_height > kMaxPixels) {
    std::snprintf(errors.message, sizeof errors.message, "the image is too large (%ux%u)",
                  info.image_width, info.image_height);
    return JpegResult::kFailed;
  }
  const bool grey = info.num_components == 1;
  info.out_color_space = grey ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(&info);
  image.create(int(info.output_height), int(info.output_width), grey ? CV_8UC1 : CV_8UC3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = image.ptr(int(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  return JpegResult::kDecoded;
}

// The decoded JPEG, or an empty Mat for a four-component file (decoded by imdecode instead).
cv::Mat decode_jpeg(const std::vector<unsigned char>& bytes, const std::string& name) {
  jpeg_decompress_struct info{};
  JpegErrors errors;
  info.err = jpeg_std_error(&errors.manager);
  errors.manager.error_exit = jpeg_on_error;
  errors.manager.emit_message = jpeg_on_message;
  errors.manager.output_message = jpeg_on_output;
  cv::Mat image;
  JpegResult result = JpegResult::kFailed;
  if (!setjmp(errors.jump)) {  // jpeg_create_decompress reports a failure through error_exit
    jpeg_create_decompress(&info);
    result = read_jpeg_pixels(info, errors, bytes, image);
  }
  jpeg_destroy_decompress(&info);
  if (result == JpegResult::kFailed) fail("{}: cannot decode JPEG ({})", name, errors.message);
  if (result == JpegResult::kCmyk) return {};
  return image;
}

// An 8- or 16-bit image file decoded as imread(IMREAD_UNCHANGED) does; throws Error naming the
// file otherwise.
cv::Mat decode(const fs::path& path) {
  check_input_file(path, "an image");
  if (!fs::is_regular_file(path)) fail("{}: no such file", path.string());
  std::vector<unsigned char> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail("{}: cannot open image", path.string());
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (in.bad()) fail("{}: cannot read image", path.string());
  }
  check_encoded(bytes, path.string());
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPng, 8) == 0)
    return decode_png(bytes, path.string());
  if (bytes.size() >= 2 && bytes[0] == 0xFF && bytes[1] == 0xD8) {
    cv::Mat jpeg = decode_jpeg(bytes, path.string());
    if (!jpeg.empty()) return jpeg;
  }
  const cv::Mat m = detail::decode_other(bytes, path.string());
  if (m.depth() != CV_8U && m.depth() != CV_16U)
    fail("{}: unsupported bit depth (8- or 16-bit expected)", path.string());
  return m;
}

std::uint32_t big_endian32(const unsigned char* p) {
  return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3];
}

// Width and height of the IHDR chunk, which the PNG specification puts right after the signature.
ImageSize png_size(std::istream& in, const std::string& name) {
  unsigned char h[24];  // signature (8), chunk length (4), "IHDR" (4), width (4), height (4)
  if (!in.read(reinterpret_cast<char*>(h), sizeof h)) fail("{}: truncated PNG header", name);
  if (std::memcmp(h + 12, "IHDR", 4) != 0) fail("{}: malformed PNG header (no IHDR chunk)", name);
  const std::uint32_t w = big_endian32(h + 16), hh = big_endian32(h + 20);
  if (w == 0 || hh == 0 || w > INT32_MAX || hh > INT32_MAX)
    fail("{}: malformed PNG header (size {}x{})", name, w, hh);
  return {int(w), int(hh)};
}

// Walks the JPEG marker segments up to the first SOFn (start of frame), which holds the size.
ImageSize jpeg_size(std::istream& in, const std::string& name) {
  in.ignore(2);  // SOI
  for (;;) {
    int marker = in.get();
    if (marker != 0xFF) {
      if (marker == std::char_traits<char>::eof()) fail("{}: truncated JPEG header", name);
      fail("{}: malformed JPEG header (expected a marker)", name);
    }
    while (marker == 0xFF) marker = in.get();  // fill bytes
    if (marker == std::char_traits<char>::eof()) fail("{}: truncated JPEG header", name);
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8))
      continue;  // TEM, RSTn, SOI: no length
    if (marker == 0xD9 || marker == 0xDA)
      fail("{}: malformed JPEG header (no frame header before the image data)", name);
    unsigned char seg[7];  // length (2), then for SOFn: precision (1), height (2), width (2)
    if (!in.read(reinterpret_cast<char*>(seg), 2)) fail("{}: truncated JPEG header", name);
    const int length = seg[0] << 8 | seg[1];
    if (length < 2) fail("{}: malformed JPEG header (segment length {})", name, length);
    // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC), which share the range.
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (length < 7 || !in.read(reinterpret_cast<char*>(seg + 2), 5))
        fail("{}: truncated JPEG header", name);
      const int h = seg[3] << 8 | seg[4], w = seg[5] << 8 | seg[6];
      if (w == 0 || h == 0) fail("{}: malformed JPEG header (size {}x{})", name, w, h);
      return {w, h};
    }
    in.ignore(length - 2);
    if (in.gcount() != length - 2) fail("{}: truncated JPEG header", name);
  }
}

// 1 where the one-channel `m` is > 127 on the 8-bit scale (65535 = 255 * 257, so 127 * 257 on the
// 16-bit one), else 0.
Image threshold_mask(cv::Mat m) {
  const double threshold = m.depth() == CV_8U ? 127 : 127 * 257;
  Image mask(m.cols, m.rows, 1);
  cv::Mat out(m.rows, m.cols, CV_32FC1, mask.data.data());
  cv::threshold(m, m, threshold, 1, cv::THRESH_BINARY);
  m.convertTo(out, CV_32F);
  return mask;
}

}  // namespace

Image read_image(const fs::path& path) {
  const cv::Mat m = decode(path);
  cv::Mat scaled;
  m.convertTo(scaled, CV_32F, m.depth() == CV_8U ? 1.0 / 255.0 : 1.0 / 65535.0);
  if (scaled.channels() == 2) cv::extractChannel(scaled, scaled, 0);  // grey + alpha
  Image image(m.cols, m.rows, 3);
  cv::Mat rgb(m.rows, m.cols, CV_32FC3, image.data.data());  // cvtColor writes in place
  const int code[] = {0, cv::COLOR_GRAY2RGB, 0, cv::COLOR_BGR2RGB, cv::COLOR_BGRA2RGB};
  cv::cvtColor(scaled, rgb, code[scaled.channels()]);
  return image;
}

Image read_mask(const fs::path& path) {
  cv::Mat m = decode(path);
  if (m.channels() == 2) cv::extractChannel(m, m, 0);
  if (m.channels() >= 3)
    cv::cvtColor(m, m, m.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  return threshold_mask(m);
}

std::optional<Image> read_alpha_mask(const fs::path& path) {
  const cv::Mat m = decode(path);
  if (m.channels() != 2 && m.channels() != 4) return std::nullopt;
  cv::Mat alpha;
  cv::extractChannel(m, alpha, m.channels() - 1);
  return threshold_mask(alpha);
}

ImageSize read_image_size(const fs::path& path) {
  check_input_file(path, "an image");
  if (!fs::is_regular_file(path)) fail("{}: no such file", path.string());
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("{}: cannot open file", path.string());
  char magic[8] = {};
  in.read(magic, sizeof magic);
  in.clear();
  in.seekg(0);
  if (std::memcmp(magic, "\x89PNG\r\n\x1a\n", 8) == 0) return png_size(in, path.string());
  if (std::memcmp(magic, "\xFF\xD8", 2) == 0) return jpeg_size(in, path.string());
  const cv::Mat m = decode(path);
  return {m.cols, m.rows};
}

namespace {
// Throws Error naming `path` unless `image` is a 1-, 3- or 4-channel buffer of its size.
void check_writable(const fs::path& path, const Image& image, const char* format) {
  const int c = image.channels;
  if (c != 1 && c != 3 && c != 4)
    fail("{}: {} needs 1, 3 or 4 channels, not {}", path.string(), format, c);
  if (image.width <= 0 || image.height <= 0 || image.data.size() != image.pixels() * c)
    fail("{}: image buffer does not match its size {}x{}x{}", path.string(), image.width,
         image.height, c);
}

// PNG through libpng directly, as decoding, so that writing a scene's images needs no OpenCV
// image codec (the lean GPU build has none: CMakeLists.txt). imencode's settings for speed: the
// SUB filter, zlib's fastest level and its run-length strategy.
void png_write_bytes(png_structp png, png_bytep data, png_size_t size) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), size);
}

void png_flush_nothing(png_structp) {}

// Encodes `codes` (8- or 16-bit grey, RGB or RGBA) into `bytes`. False on a libpng error, its
// message kept by png_on_error. `bytes` and `rows` live in the caller's frame: libpng's errors
// return here by longjmp.
bool write_png_pixels(png_structp png, png_infop info, const cv::Mat& codes, std::string& bytes,
                      std::vector<png_bytep>& rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_write_fn(png, &bytes, png_write_bytes, png_flush_nothing);
  const int color_type[] = {0, PNG_COLOR_TYPE_GRAY, 0, PNG_COLOR_TYPE_RGB,
                            PNG_COLOR_TYPE_RGB_ALPHA};
  const int bits = codes.depth() == CV_16U ? 16 : 8;
  png_set_IHDR(png, info, png_uint_32(codes.cols), png_uint_32(codes.rows), bits,
               color_type[codes.channels()], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  png_write_info(png, info);
  if (bits == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  rows.resize(std::size_t(codes.rows));
  for (int y = 0; y < codes.rows; ++y) rows[std::size_t(y)] = const_cast<png_bytep>(codes.ptr(y));
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  return true;
}

std::string encode_png(const cv::Mat& codes, const std::string& name) {
  PngSource errors{nullptr};  // png_on_error keeps the message here
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &errors, png_on_error, png_on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    fail("{}: cannot encode PNG (out of memory)", name);
  }
  std::string bytes;
  std::vector<png_bytep> rows;
  const bool ok = write_png_pixels(png, info, codes, bytes, rows);
  png_destroy_write_struct(&png, &info);
  if (!ok) fail("{}: cannot encode PNG ({})", name, errors.message);
  return bytes;
}
}  // namespace

void write_png(const fs::path& path, const Image& image, int bits, bool replace) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return char(std::tolower(ch)); });
  if (ext != ".png") fail("{}: write_png needs a .png file name", path.string());
  if (bits != 8 && bits != 16)
    fail("{}: PNG bit depth must be 8 or 16, not {}", path.string(), bits);
  check_writable(path, image, "PNG");
  const cv::Mat values(image.height, image.width, CV_32FC(image.channels),
                       const_cast<float*>(image.data.data()));
  cv::Mat codes;  // convertTo rounds to nearest and saturates (NaN becomes 0)
  values.convertTo(codes, bits == 8 ? CV_8U : CV_16U, bits == 8 ? 255.0 : 65535.0);
  // Written through a checked stream: a write that fails on a full disk is reported.
  write_text_file(path, encode_png(codes, path.string()), replace);
}

void check_exr_writer(const fs::path& path) {
  if (!can_write_exr())
    fail("{}: this build's OpenCV cannot write OpenEXR (built without it); write PNGs instead",
         path.string());
}

void write_exr(const fs::path& path, const Image& image, bool float32, bool replace) {
  check_exr_writer(path);
  check_writable(path, image, "EXR");
  const int c = image.channels;
  cv::Mat values(image.height, image.width, CV_32FC(c));
  float* v = values.ptr<float>();
  std::copy(image.data.begin(), image.data.end(), v);
  if (c == 4)  // premultiplied, as EXR defines alpha
    for (std::size_t i = 0; i < image.pixels(); ++i)
      for (int k = 0; k < 3; ++k) v[4 * i + k] *= image.data[4 * i + 3];
  if (c == 3) cv::cvtColor(values, values, cv::COLOR_RGB2BGR);  // OpenCV's codecs take BGR(A)
  if (c == 4) cv::cvtColor(values, values, cv::COLOR_RGBA2BGRA);
  const std::vector<unsigned char> bytes = detail::encode_exr(values, float32, path.string());
  write_text_file(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                  replace);
}

void quiet_opencv_log() {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
}

}  // namespace retimegs::media
