#pragma once
// Messages printed as one line. An error or warning quotes user strings (file names, camera names,
// JSON values) that may hold a newline or a terminal escape; printed raw, one message would span
// several lines (breaking "one line per failure") or drive the terminal.
#include <string>
#include <string_view>

namespace retimegs {

// `text` with every control byte (< 0x20 and 0x7f) written as a visible escape: \n, \r, \t, the
// others as \xHH (ESC is \x1b). Every other byte is kept, UTF-8 included, and so are backslashes
// (a file name's "\n" and an escaped newline then read alike: the message is for a person).
std::string escape_control_chars(std::string_view text);

}  // namespace retimegs
