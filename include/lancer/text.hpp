// Text from outside (file names, mostly) made fit for a one-line message.
#pragma once

#include <cstdio>
#include <string>

namespace lancer {

// `s` with every control character written as an escape: \n, \r, \t,
// else \xHH; C1 controls (U+0080..U+009F, which some terminals obey as escape sequences too)
// as \u00HH. `changed` tells whether anything was escaped. Other bytes (UTF-8 text) as is.
inline std::string escape_controls(const std::string& s, bool* changed = nullptr) {
  std::string out;
  out.reserve(s.size());
  bool any = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    char hex[8];
    if (c == '\n' || c == '\r' || c == '\t') {
      out += c == '\n' ? "\\n" : c == '\r' ? "\\r" : "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else if (c == 0xc2 && i + 1 < s.size() && static_cast<unsigned char>(s[i + 1]) >= 0x80 &&
               static_cast<unsigned char>(s[i + 1]) <= 0x9f) {
      std::snprintf(hex, sizeof hex, "\\u%04x", static_cast<unsigned char>(s[++i]));
      out += hex;
    } else {
      out += static_cast<char>(c);
      continue;
    }
    any = true;
  }
  if (changed) *changed = any;
  return out;
}

// A file name as every message shows it: as is when it is plain printable text (the common
// case, so messages read as before); else in double quotes, with control characters escaped
// (escape_controls) and any backslash or double quote escaped too, so that a name holding a
// newline or a terminal escape sequence keeps the message on one line and is shown, not obeyed.
inline std::string shown_path(const std::string& path) {
  bool changed = false;
  escape_controls(path, &changed);
  if (!changed) return path;
  std::string quoted;
  for (char c : path) {
    if (c == '\\' || c == '"') quoted += '\\';
    quoted += c;
  }
  return "\"" + escape_controls(quoted) + "\"";
}

}  // namespace lancer
