#include <cmath>
#include <cstdint>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::media {
namespace {
using test::read_text;
using test::shared_data;
using test::TempDir;
using test::write_text;

constexpr const char* kJpeg = "panoptic-basketball/ims/0/000000.jpg";
constexpr const char* kPng = "flow/middlebury-rubberwhale/frame10.png";

using test::expect_error;

// A 4x3 image whose code values (0..max) are a function of pixel and channel.
Image coded_image(int channels, int max_code) {
  Image image(4, 3, channels);
  for (std::size_t i = 0; i < image.data.size(); ++i)
    image.data[i] = float((i * 7919) % (max_code + 1)) / float(max_code);
  image.data[0] = 0.0f;
  image.data[1] = 1.0f;
  return image;
}

TEST(ImageIo, EightBitRoundTripIsExactAndStoredAsBgr) {
  TempDir dir;
  const Image image = coded_image(3, 255);
  write_png(dir / "a.png", image);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
  const Image back = read_image(dir / "a.png");
  ASSERT_EQ(back.width, 4);
  ASSERT_EQ(back.height, 3);
  ASSERT_EQ(back.channels, 3);
  for (std::size_t i = 0; i < image.data.size(); ++i) EXPECT_FLOAT_EQ(back.data[i], image.data[i]);
  const cv::Mat raw = cv::imread((dir / "a.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_8UC3);
  const cv::Vec3b bgr = raw.at<cv::Vec3b>(2, 1);  // pixel (x=1, y=2)
  for (int c = 0; c < 3; ++c) EXPECT_EQ(bgr[2 - c], std::lround(image.at(2, 1, c) * 255.0f)) << c;
}

TEST(ImageIo, SixteenBitRoundTripIsExact) {
  TempDir dir;
  const Image image = coded_image(3, 65535);
  write_png(dir / "a.png", image, 16);
  const cv::Mat raw = cv::imread((dir / "a.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC3);
  EXPECT_EQ(raw.at<cv::Vec3w>(0, 0)[2], 0);  // R of pixel 0 is stored last
  EXPECT_EQ(raw.at<cv::Vec3w>(0, 0)[1], 65535);
  const Image back = read_image(dir / "a.png");
  ASSERT_EQ(back.data.size(), image.data.size());
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    EXPECT_EQ(std::lround(back.data[i] * 65535.0f), std::lround(image.data[i] * 65535.0f)) << i;
    EXPECT_NEAR(back.data[i], image.data[i], 1e-7f) << i;
  }
}

// Every layout write_png takes (grey and RGBA here; RGB above) at 8 and 16 bits, as OpenCV's own
// decoder reads it back: the codes, the channel order (BGRA in OpenCV), the byte order.
TEST(ImageIo, GreyAndRgbaPngsDecodeWithOpenCvAtBothDepths) {
  TempDir dir;
  for (const int channels : {1, 4})
    for (const int bits : {8, 16}) {
      const int max_code = bits == 8 ? 255 : 65535;
      const Image image = coded_image(channels, max_code);
      const auto path =
          dir / ("x" + std::to_string(channels) + "_" + std::to_string(bits) + ".png");
      write_png(path, image, bits);
      const cv::Mat raw = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(raw.type(), CV_MAKETYPE(bits == 8 ? CV_8U : CV_16U, channels)) << path;
      const int order[4] = {2, 1, 0, 3};  // stored channel of R, G, B, A
      for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 4; ++x)
          for (int c = 0; c < channels; ++c) {
            const int stored = channels == 1 ? 0 : order[c];
            const long code = bits == 8 ? long(raw.ptr<std::uint8_t>(y)[x * channels + stored])
                                        : long(raw.ptr<std::uint16_t>(y)[x * channels + stored]);
            EXPECT_EQ(code, std::lround(image.at(y, x, c) * float(max_code)))
                << path << " x " << x << " y " << y << " c " << c;
          }
    }
}

TEST(ImageIo, WriteClampsAndRounds) {
  TempDir dir;
  Image image(4, 1, 1);
  image.data = {-0.5f, 1.5f, 100.4f / 255.0f, std::nanf("")};
  write_png(dir / "c.png", image);
  const cv::Mat raw = cv::imread((dir / "c.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_8UC1);
  EXPECT_EQ(raw.at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(raw.at<std::uint8_t>(0, 1), 255);
  EXPECT_EQ(raw.at<std::uint8_t>(0, 2), 100);
  EXPECT_EQ(raw.at<std::uint8_t>(0, 3), 0);
}

TEST(ImageIo, GreyExpandsToRgbAndAlphaIsDropped) {
  TempDir dir;
  const Image grey = coded_image(1, 255);
  write_png(dir / "g.png", grey);
  const Image rgb = read_image(dir / "g.png");
  ASSERT_EQ(rgb.channels, 3);
  for (std::size_t p = 0; p < grey.pixels(); ++p)
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(rgb.data[3 * p + c], grey.data[p]);

  const Image rgba = coded_image(4, 255);
  write_png(dir / "a.png", rgba, 16);
  const Image back = read_image(dir / "a.png");
  ASSERT_EQ(back.channels, 3);
  for (std::size_t p = 0; p < rgba.pixels(); ++p)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.data[3 * p + c], rgba.data[4 * p + c], 1e-7f);
}

TEST(ImageIo, MaskThresholdIs127OnTheEightBitScale) {
  TempDir dir;
  cv::Mat m8 = (cv::Mat_<std::uint8_t>(1, 4) << 0, 127, 128, 255);
  cv::Mat m16 = (cv::Mat_<std::uint16_t>(1, 4) << 0, 127 * 257, 127 * 257 + 1, 65535);
  ASSERT_TRUE(cv::imwrite((dir / "m8.png").string(), m8));
  ASSERT_TRUE(cv::imwrite((dir / "m16.png").string(), m16));
  for (const char* name : {"m8.png", "m16.png"}) {
    const Image mask = read_mask(dir / name);
    ASSERT_EQ(mask.channels, 1);
    EXPECT_EQ(mask.data, (std::vector<float>{0, 0, 1, 1})) << name;
  }
}

TEST(ImageIo, AlphaMaskIsTheAlphaChannelThresholdedAt127) {
  TempDir dir;
  cv::Mat rgba8(1, 4, CV_8UC4, cv::Scalar(200, 100, 50, 0));
  for (int x = 0; x < 4; ++x) rgba8.at<cv::Vec4b>(0, x)[3] = std::uint8_t(x == 0 ? 0 : 126 + x);
  cv::Mat rgba16(1, 4, CV_16UC4, cv::Scalar(9, 9, 9, 0));
  for (int x = 0; x < 4; ++x)
    rgba16.at<cv::Vec4w>(0, x)[3] = std::uint16_t(x < 2 ? x * 127 * 257 : 127 * 257 + x);
  ASSERT_TRUE(cv::imwrite((dir / "a8.png").string(), rgba8));
  ASSERT_TRUE(cv::imwrite((dir / "a16.png").string(), rgba16));
  ASSERT_TRUE(cv::imwrite((dir / "rgb.png").string(), cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 2, 3))));
  for (const char* name : {"a8.png", "a16.png"}) {
    const std::optional<Image> mask = read_alpha_mask(dir / name);
    ASSERT_TRUE(mask) << name;
    ASSERT_EQ(mask->channels, 1);
    EXPECT_EQ(mask->data, (std::vector<float>{0, 0, 1, 1})) << name;
  }
  EXPECT_FALSE(read_alpha_mask(dir / "rgb.png"));
  test::expect_error([&] { read_alpha_mask(dir / "missing.png"); }, {"missing.png"});
}

TEST(ImageIo, ReadsJpegLikeOpenCv) {
  RETIMEGS_REQUIRE_DATA(kJpeg);
  const auto path = shared_data() / kJpeg;
  const Image image = read_image(path);
  EXPECT_EQ(image.width, 640);
  EXPECT_EQ(image.height, 360);
  EXPECT_EQ(image.channels, 3);
  const cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR);
  for (const auto& [x, y] : {std::pair{0, 0}, {639, 359}, {320, 100}, {17, 300}}) {
    const cv::Vec3b v = bgr.at<cv::Vec3b>(y, x);
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(image.at(y, x, c), v[2 - c] / 255.0f);
  }
}

TEST(ImageIo, HeaderSizeMatchesDecodedSize) {
  RETIMEGS_REQUIRE_DATA(kJpeg);
  RETIMEGS_REQUIRE_DATA(kPng);
  for (const auto& [rel, w, h] : {std::tuple{kJpeg, 640, 360},
                                  {kPng, 584, 388},
                                  {"flow/sintel-alley_1-clean/frame_0002.png", 1024, 436}}) {
    const ImageSize size = read_image_size(shared_data() / rel);
    const cv::Mat decoded = cv::imread((shared_data() / rel).string());
    EXPECT_EQ(size.width, w) << rel;
    EXPECT_EQ(size.height, h) << rel;
    EXPECT_EQ(size.width, decoded.cols) << rel;
    EXPECT_EQ(size.height, decoded.rows) << rel;
  }
  TempDir dir;
  ASSERT_TRUE(cv::imwrite((dir / "b.bmp").string(), cv::Mat(7, 5, CV_8UC3, cv::Scalar(1, 2, 3))));
  const ImageSize bmp = read_image_size(dir / "b.bmp");
  EXPECT_EQ(bmp.width, 5);
  EXPECT_EQ(bmp.height, 7);
}

TEST(ImageIo, MissingAndCorruptFilesNameThePath) {
  RETIMEGS_REQUIRE_DATA(kJpeg);
  RETIMEGS_REQUIRE_DATA(kPng);
  TempDir dir;
  const std::string missing = (dir / "missing.png").string();
  expect_error([&] { read_image(missing); }, {missing, "no such file"});
  expect_error([&] { read_image_size(missing); }, {missing, "no such file"});
  expect_error([&] { read_mask(missing); }, {missing, "no such file"});

  const std::string png = read_text(shared_data() / kPng), jpg = read_text(shared_data() / kJpeg);
  write_text(dir / "cut.png", png.substr(0, 1000));
  // Damage is found before libpng / libjpeg, which would print their own lines on stderr.
  expect_error([&] { read_image(dir / "cut.png"); }, {(dir / "cut.png").string(), "truncated PNG"});
  std::string flipped = png;
  flipped[100] = char(flipped[100] ^ 0x01);
  write_text(dir / "flipped.png", flipped);
  expect_error([&] { read_image(dir / "flipped.png"); }, {"flipped.png", "CRC mismatch"});
  write_text(dir / "cut.jpg", jpg.substr(0, jpg.size() / 2));
  expect_error([&] { read_image(dir / "cut.jpg"); }, {"cut.jpg", "truncated JPEG"});
  write_text(dir / "head.png", png.substr(0, 20));
  expect_error([&] { read_image_size(dir / "head.png"); }, {"head.png", "truncated PNG header"});
  write_text(dir / "head.jpg", jpg.substr(0, 100));
  expect_error([&] { read_image_size(dir / "head.jpg"); }, {"head.jpg", "truncated JPEG header"});
  write_text(dir / "junk.png", "this is not an image at all");
  expect_error([&] { read_image(dir / "junk.png"); }, {"junk.png", "cannot decode"});
  expect_error([&] { read_image_size(dir / "junk.png"); }, {"junk.png", "cannot decode"});
}

TEST(ImageIo, FailedWritesLeaveNoFile) {
  TempDir dir;
  expect_error([&] { write_png(dir / "a.png", Image(2, 2, 2)); }, {"a.png", "channels"});
  expect_error([&] { write_png(dir / "a.png", Image(2, 2, 3), 12); }, {"a.png", "bit depth"});
  expect_error([&] { write_png(dir / "a.jpg", Image(2, 2, 3)); }, {"a.jpg", ".png"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace retimegs::media
