// PNG and JPEG decoding (io/image_io.cpp decodes them with libpng and libjpeg itself): every PNG
// colour type and bit depth, grey and colour JPEGs decode as imdecode(IMREAD_UNCHANGED) does, the
// libraries' warnings print nothing, and a file that fails inside its data becomes one Error
// naming it, with nothing on stderr. The PNGs are built here byte by byte (stored deflate
// blocks, correct CRCs).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::media {
namespace {
namespace fs = std::filesystem;
using Bytes = std::vector<unsigned char>;

std::uint32_t crc32(const unsigned char* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = crc & 1 ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
  }
  return ~crc;
}

void put32(Bytes& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back((v >> s) & 0xFF);
}

void chunk(Bytes& png, const char* type, const Bytes& data) {
  put32(png, std::uint32_t(data.size()));
  const std::size_t start = png.size();
  png.insert(png.end(), type, type + 4);
  png.insert(png.end(), data.begin(), data.end());
  put32(png, crc32(png.data() + start, png.size() - start));
}

// A zlib stream of stored (uncompressed) deflate blocks.
Bytes zlib_stored(const Bytes& raw) {
  Bytes z = {0x78, 0x01};
  std::size_t at = 0;
  do {
    const std::size_t n = std::min<std::size_t>(raw.size() - at, 65535);
    z.push_back(at + n == raw.size() ? 1 : 0);
    z.push_back(n & 0xFF), z.push_back(n >> 8);
    z.push_back(~n & 0xFF), z.push_back((~n >> 8) & 0xFF);
    z.insert(z.end(), raw.begin() + at, raw.begin() + at + n);
    at += n;
  } while (at < raw.size());
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
  put32(z, b << 16 | a);
  return z;
}

struct PngSpec {
  std::string label;
  int width = 5, height = 3, bit_depth = 8,
      color_type = 2;  // 0 grey, 2 RGB, 3 palette, 4 GA, 6 RGBA
  bool trns = false, interlaced = false;
  Bytes extra_chunk_type, extra_chunk;  // an ancillary chunk before IDAT (e.g. iCCP)
};

int samples(int color_type) {
  return color_type == 2 ? 3 : color_type == 4 ? 2 : color_type == 6 ? 4 : 1;
}

// Packed scanline bytes of one row of `width` pixels, values from a fixed pseudo-random sequence.
Bytes row_bytes(const PngSpec& s, int width, std::uint32_t& state) {
  const int bits = s.bit_depth * samples(s.color_type);
  Bytes row((std::size_t(width) * bits + 7) / 8);
  for (auto& byte : row) {
    state = state * 1664525u + 1013904223u;
    byte = state >> 24;
  }
  if (s.color_type == 3) {  // palette indices below the palette's 6 entries
    const int per_byte = 8 / s.bit_depth;
    for (int x = 0; x < width; ++x) {
      const int shift = 8 - s.bit_depth * (x % per_byte + 1);
      auto& byte = row[x / per_byte];
      const int mask = ((1 << s.bit_depth) - 1) << shift;
      const int index = ((byte & mask) >> shift) % 6;
      byte = (byte & ~mask) | (index << shift);
    }
  }
  return row;
}

Bytes build_png(const PngSpec& s) {
  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  Bytes ihdr;
  put32(ihdr, s.width), put32(ihdr, s.height);
  ihdr.insert(ihdr.end(), {std::uint8_t(s.bit_depth), std::uint8_t(s.color_type), 0, 0,
                           std::uint8_t(s.interlaced ? 1 : 0)});
  chunk(png, "IHDR", ihdr);
  if (!s.extra_chunk_type.empty())
    chunk(png, reinterpret_cast<const char*>(s.extra_chunk_type.data()), s.extra_chunk);
  if (s.color_type == 3)
    chunk(png, "PLTE", {10, 20, 30, 200, 100, 0, 7, 250, 90, 255, 255, 255, 0, 0, 0, 128, 64, 32});
  if (s.trns) {
    if (s.color_type == 3) chunk(png, "tRNS", {255, 0, 128, 77});
    if (s.color_type == 0) chunk(png, "tRNS", {0, 1});
    if (s.color_type == 2) chunk(png, "tRNS", {0, 1, 0, 2, 0, 3});
  }
  Bytes raw;
  std::uint32_t state = 12345;
  // Adam7 passes (x0, y0, dx, dy); one pass covering everything when not interlaced.
  const int passes[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                            {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
  for (int p = 0; p < (s.interlaced ? 7 : 1); ++p) {
    const int* q = s.interlaced ? passes[p] : nullptr;
    const int w = q ? (s.width - q[0] + q[2] - 1) / q[2] : s.width;
    const int h = q ? (s.height - q[1] + q[3] - 1) / q[3] : s.height;
    if (w <= 0 || h <= 0) continue;
    for (int y = 0; y < h; ++y) {
      raw.push_back(0);  // filter: none
      const Bytes row = row_bytes(s, w, state);
      raw.insert(raw.end(), row.begin(), row.end());
    }
  }
  chunk(png, "IDAT", zlib_stored(raw));
  chunk(png, "IEND", {});
  return png;
}

void write_bytes(const fs::path& path, const Bytes& bytes) {
  test::write_text(path, std::string(bytes.begin(), bytes.end()));
}

// What `run` writes on stderr (file descriptor 2, where libpng prints).
std::string stderr_of(const std::function<void()>& run) {
  test::TempDir dir;
  const fs::path file = dir / "stderr.txt";
  std::fflush(stderr);
  const int saved = ::dup(2);
  FILE* f = std::fopen(file.c_str(), "w");
  ::dup2(::fileno(f), 2);
  try {
    run();
  } catch (...) {
    std::fflush(stderr);
    ::dup2(saved, 2), ::close(saved), std::fclose(f);
    throw;
  }
  std::fflush(stderr);
  ::dup2(saved, 2), ::close(saved), std::fclose(f);
  return test::read_text(file);
}

// read_image's result from imdecode(IMREAD_UNCHANGED): RGB in [0, 1] (scaled as read_image does).
Image reference_image(const Bytes& bytes) {
  const cv::Mat m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  EXPECT_FALSE(m.empty());
  cv::Mat f;
  m.convertTo(f, CV_32F, m.depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0);
  Image out(m.cols, m.rows, 3);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      for (int c = 0; c < 3; ++c) {
        const int channel = m.channels() >= 3 ? 2 - c : 0;  // BGR(A) -> RGB; grey -> all three
        out.data[(std::size_t(y) * m.cols + x) * 3 + c] =
            f.ptr<float>(y)[x * m.channels() + channel];
      }
  return out;
}

PngSpec spec(std::string label, int width, int height, int bit_depth, int color_type,
             bool trns = false, bool interlaced = false) {
  PngSpec s;
  s.label = std::move(label);
  s.width = width, s.height = height, s.bit_depth = bit_depth, s.color_type = color_type;
  s.trns = trns, s.interlaced = interlaced;
  return s;
}

std::vector<PngSpec> every_kind() {
  std::vector<PngSpec> specs;
  for (int depth : {1, 2, 4, 8, 16}) specs.push_back(spec("grey", 5, 3, depth, 0));
  specs.push_back(spec("grey+tRNS", 5, 3, 8, 0, true));
  for (int depth : {8, 16}) {
    specs.push_back(spec("grey+alpha", 5, 3, depth, 4));
    specs.push_back(spec("rgb", 5, 3, depth, 2));
    specs.push_back(spec("rgb+tRNS", 5, 3, depth, 2, true));
    specs.push_back(spec("rgba", 5, 3, depth, 6));
  }
  for (int depth : {1, 2, 4, 8}) {
    specs.push_back(spec("palette", 7, 3, depth, 3));
    specs.push_back(spec("palette+tRNS", 7, 3, depth, 3, true));
  }
  specs.push_back(spec("rgb interlaced", 11, 9, 8, 2, false, true));
  specs.push_back(spec("grey16 interlaced", 3, 10, 16, 0, false, true));
  return specs;
}

TEST(PngDecode, EveryKindDecodesAsImdecodeUnchanged) {
  test::TempDir dir;
  for (const PngSpec& spec : every_kind()) {
    const std::string name = spec.label + " " + std::to_string(spec.bit_depth);
    const Bytes bytes = build_png(spec);
    write_bytes(dir / "a.png", bytes);
    const Image expected = reference_image(bytes);
    Image got, mask;
    EXPECT_EQ(stderr_of([&] { got = read_image(dir / "a.png"), mask = read_mask(dir / "a.png"); }),
              "")
        << name;
    ASSERT_EQ(got.width, expected.width) << name;
    ASSERT_EQ(got.height, expected.height) << name;
    EXPECT_EQ(got.data, expected.data) << name;
    EXPECT_EQ(mask.width, spec.width) << name;
  }
}

// An iCCP chunk whose profile libpng rejects (a benign error, reported as a warning): imdecode
// lets libpng print "libpng warning: iCCP: ..."; read_image prints nothing and gives the pixels
// of the same file without the chunk.
TEST(PngDecode, WarningsPrintNothingAndChangeNothing) {
  test::TempDir dir;
  PngSpec plain = spec("rgb", 6, 4, 8, 2);
  PngSpec with_iccp = plain;
  with_iccp.extra_chunk_type = {'i', 'C', 'C', 'P'};
  with_iccp.extra_chunk = {'x', 0, 0};  // profile name "x", compression 0, then the profile
  const Bytes profile = zlib_stored(Bytes(200, 7));  // 200 bytes: not an ICC profile
  with_iccp.extra_chunk.insert(with_iccp.extra_chunk.end(), profile.begin(), profile.end());
  write_bytes(dir / "plain.png", build_png(plain));
  write_bytes(dir / "iccp.png", build_png(with_iccp));

  // The test's premise: this file makes libpng warn through imdecode.
  const Bytes iccp = build_png(with_iccp);
  const std::string opencv_err = stderr_of([&] { cv::imdecode(iccp, cv::IMREAD_UNCHANGED); });
  EXPECT_NE(opencv_err.find("iCCP"), std::string::npos) << opencv_err;

  Image a, b;
  EXPECT_EQ(stderr_of([&] { a = read_image(dir / "iccp.png"); }), "");
  b = read_image(dir / "plain.png");
  EXPECT_EQ(a.data, b.data);
  EXPECT_EQ(a.width, 6);
}

// Damage inside the compressed data with every CRC valid: one Error naming the file and libpng's
// reason, nothing printed.
TEST(PngDecode, DamagedDataBehindValidCrcsIsOneErrorNamingTheFile) {
  test::TempDir dir;
  const Bytes good = build_png(spec("rgb", 40, 30, 8, 2));
  // The IDAT chunk cut to half its data (length and CRC rewritten).
  Bytes cut(good.begin(), good.begin() + 33);  // signature + IHDR
  const std::uint32_t length =
      std::uint32_t(good[33]) << 24 | good[34] << 16 | good[35] << 8 | good[36];
  const Bytes half(good.begin() + 41, good.begin() + 41 + length / 2);
  chunk(cut, "IDAT", half);
  chunk(cut, "IEND", {});
  // A stored block whose length check (NLEN) is wrong, and a stream whose header is not zlib's.
  Bytes nlen = good;
  Bytes bad_header = good;
  bad_header[41] = 0x12;
  nlen[41 + 5] ^= 0xFF;
  for (Bytes* b : {&nlen, &bad_header}) {
    const std::size_t crc_at = 41 + length;
    const std::uint32_t crc = crc32(b->data() + 37, 4 + length);
    for (int i = 0; i < 4; ++i) (*b)[crc_at + i] = (crc >> (24 - 8 * i)) & 0xFF;
  }
  for (const auto& [name, bytes] :
       {std::pair{"cut.png", cut}, {"nlen.png", nlen}, {"header.png", bad_header}}) {
    const fs::path path = dir / name;
    write_bytes(path, bytes);
    std::string message;
    const std::string err = stderr_of([&] {
      try {
        read_image(path);
      } catch (const Error& e) {
        message = e.what();
      }
    });
    EXPECT_EQ(err, "") << name;
    EXPECT_NE(message.find(path.string() + ": cannot decode PNG ("), std::string::npos)
        << name << ": " << message;
  }
}

Bytes encode_jpeg(const cv::Mat& m) {
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(cv::imencode(".jpg", m, bytes, {cv::IMWRITE_JPEG_QUALITY, 90}));
  return bytes;
}

// A smooth pattern with edges, `channels` 1 or 3, odd sizes (partial MCUs).
cv::Mat pattern(int width, int height, int channels) {
  cv::Mat m(height, width, CV_8UC(channels));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < channels; ++c)
        m.ptr<std::uint8_t>(y)[x * channels + c] =
            std::uint8_t((x * 7 + y * 3 + c * 60 + (x > width / 2 ? 90 : 0)) % 256);
  return m;
}

TEST(JpegDecode, GreyAndColourDecodeAsImdecodeUnchanged) {
  test::TempDir dir;
  for (const auto& [width, height, channels] :
       {std::tuple{17, 9, 3}, {64, 48, 3}, {33, 21, 1}, {8, 8, 1}}) {
    const Bytes bytes = encode_jpeg(pattern(width, height, channels));
    write_bytes(dir / "a.jpg", bytes);
    const Image expected = reference_image(bytes);
    Image got;
    EXPECT_EQ(stderr_of([&] { got = read_image(dir / "a.jpg"); }), "");
    ASSERT_EQ(got.width, width);
    ASSERT_EQ(got.height, height);
    EXPECT_EQ(got.data, expected.data) << width << "x" << height << "x" << channels;
    const Image mask = read_mask(dir / "a.jpg");
    EXPECT_EQ(mask.width, width);
  }
}

// Two stray bytes between two header segments: libjpeg warns ("Corrupt JPEG data: 2
// extraneous bytes before marker 0xdb"), which imdecode prints; read_image prints nothing and
// gives the pixels of the clean file.
TEST(JpegDecode, WarningsPrintNothingAndChangeNothing) {
  test::TempDir dir;
  const Bytes clean = encode_jpeg(pattern(24, 16, 3));
  Bytes stray = clean;
  const std::size_t after_app0 = 4 + (clean[4] << 8 | clean[5]);  // SOI, then APP0 (JFIF)
  ASSERT_EQ(clean[after_app0], 0xFF);
  stray.insert(stray.begin() + after_app0, {0x12, 0x34});
  const std::string opencv_err = stderr_of([&] { cv::imdecode(stray, cv::IMREAD_UNCHANGED); });
  EXPECT_NE(opencv_err.find("Corrupt JPEG data"), std::string::npos) << opencv_err;
  write_bytes(dir / "clean.jpg", clean);
  write_bytes(dir / "stray.jpg", stray);
  Image a;
  EXPECT_EQ(stderr_of([&] { a = read_image(dir / "stray.jpg"); }), "");
  EXPECT_EQ(a.data, read_image(dir / "clean.jpg").data);
}

// A frame header libjpeg refuses (12-bit precision is not in the 8-bit library): one Error naming
// the file and libjpeg's reason, nothing printed.
TEST(JpegDecode, ErrorsAreOneErrorNamingTheFile) {
  test::TempDir dir;
  Bytes bytes = encode_jpeg(pattern(24, 16, 3));
  std::size_t sof = 2;
  while (sof + 4 < bytes.size() && !(bytes[sof] == 0xFF && bytes[sof + 1] == 0xC0))
    sof += 2 + (bytes[sof + 2] << 8 | bytes[sof + 3]);
  ASSERT_LT(sof + 4, bytes.size());
  bytes[sof + 4] = 7;  // sample precision
  const fs::path path = dir / "bad.jpg";
  write_bytes(path, bytes);
  std::string message;
  const std::string err = stderr_of([&] { message = test::message_of([&] { read_image(path); }); });
  EXPECT_EQ(err, "");
  EXPECT_NE(message.find(path.string() + ": cannot decode JPEG ("), std::string::npos) << message;
  EXPECT_NE(message.find("precision"), std::string::npos) << message;
}

}  // namespace
}  // namespace retimegs::media
