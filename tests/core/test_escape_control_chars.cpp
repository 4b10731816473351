#include "retimegs/core/escape_control_chars.hpp"

#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {

TEST(EscapeControlChars, EscapesControlBytesAndKeepsTheRest) {
  EXPECT_EQ(escape_control_chars("plain text: 'a/b.png' 12 \\n"), "plain text: 'a/b.png' 12 \\n");
  EXPECT_EQ(escape_control_chars("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(escape_control_chars("\x1b[31mred\x7f"), "\\x1b[31mred\\x7f");
  EXPECT_EQ(escape_control_chars(std::string("nul\0end", 7)), "nul\\x00end");
  EXPECT_EQ(escape_control_chars("\x01\x1f "), "\\x01\\x1f ");
  EXPECT_EQ(escape_control_chars("caf\xc3\xa9"), "caf\xc3\xa9");  // UTF-8 kept
  EXPECT_EQ(escape_control_chars(""), "");
}

TEST(EscapeControlChars, ResultHasNoControlByte) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += char(b);
  for (const char ch : escape_control_chars(all)) {
    const auto byte = static_cast<unsigned char>(ch);
    EXPECT_TRUE(byte >= 0x20 && byte != 0x7f) << int(byte);
  }
}

// An Error quoting user text holds it whole and on one line: what() is a C string, which a raw NUL
// would end.
TEST(EscapeControlChars, ErrorMessagesShowTheTextAfterANul) {
  EXPECT_STREQ(Error(std::string("f.json: 'name' is 'a\0b\nc'", 25)).what(),
               "f.json: 'name' is 'a\\x00b\\nc'");
  EXPECT_EQ(test::message_of([] { fail("{}: got '{}'", "scene.json", std::string("tr\0ain", 6)); }),
            "scene.json: got 'tr\\x00ain'");
}

}  // namespace
}  // namespace retimegs
