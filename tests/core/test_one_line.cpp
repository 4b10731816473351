#include "retimegs/core/one_line.hpp"

#include <string>

#include <gtest/gtest.h>

namespace retimegs {
namespace {

TEST(OneLine, EscapesControlBytesAndKeepsTheRest) {
  EXPECT_EQ(one_line("plain text: 'a/b.png' 12 \\n"), "plain text: 'a/b.png' 12 \\n");
  EXPECT_EQ(one_line("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(one_line("\x1b[31mred\x7f"), "\\x1b[31mred\\x7f");
  EXPECT_EQ(one_line(std::string("nul\0end", 7)), "nul\\x00end");
  EXPECT_EQ(one_line("\x01\x1f "), "\\x01\\x1f ");
  EXPECT_EQ(one_line("caf\xc3\xa9"), "caf\xc3\xa9");  // UTF-8 kept
  EXPECT_EQ(one_line(""), "");
}

TEST(OneLine, ResultHasNoControlByte) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += char(b);
  for (const char ch : one_line(all)) {
    const auto byte = static_cast<unsigned char>(ch);
    EXPECT_TRUE(byte >= 0x20 && byte != 0x7f) << int(byte);
  }
}

}  // namespace
}  // namespace retimegs
