// FNV-1a 64: the published test vectors, and a file hashed in chunks equals its bytes hashed whole.
#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/fnv1a.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {

TEST(Fnv1a64, MatchesThePublishedVectors) {
  const auto hash = [](const std::string& s) { return fnv1a64(s.data(), s.size()); };
  EXPECT_EQ(hash(""), 0xcbf29ce484222325ull);
  EXPECT_EQ(hash("a"), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(hash("foobar"), 0x85944171f73967e8ull);
  // Continuing a hash is hashing the concatenation.
  EXPECT_EQ(fnv1a64("bar", 3, fnv1a64("foo", 3)), hash("foobar"));
}

TEST(Fnv1a64, AFileHashesAsItsBytesAcrossReadChunks) {
  test::TempDir dir;
  std::string bytes(3 << 20, '\0');  // three 1 MiB read chunks, and then some
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = char(i * 2654435761u >> 13);
  bytes += "tail";
  test::write_text(dir / "f.bin", bytes);
  EXPECT_EQ(fnv1a64_file(dir / "f.bin"), fnv1a64(bytes.data(), bytes.size()));
  test::expect_error([&] { fnv1a64_file(dir / "missing.bin"); }, {"missing.bin"});
}

}  // namespace
}  // namespace retimegs
