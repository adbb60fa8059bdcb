#include "lane/base/excerpt.h"

#include "absl/strings/str_cat.h"

namespace lane {

std::string Excerpt(absl::string_view text, size_t max_chars) {
  static constexpr char kHex[] = "0123456789abcdef";
  const size_t shown = text.size() < max_chars ? text.size() : max_chars;
  std::string out;
  out.reserve(shown + 16);
  for (size_t i = 0; i < shown; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    switch (c) {
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      default:
        if (c >= 0x20 && c < 0x7F) {
          out += static_cast<char>(c);
        } else {
          out += "\\x";
          out += kHex[c >> 4];
          out += kHex[c & 0xF];
        }
    }
  }
  if (shown < text.size()) absl::StrAppend(&out, "... (", text.size(), " bytes)");
  return out;
}

std::string QuotedExcerpt(absl::string_view text, size_t max_chars) {
  return absl::StrCat("\"", Excerpt(text, max_chars), "\"");
}

std::string CapMessage(absl::string_view message, size_t max_bytes) {
  if (message.size() <= max_bytes) return std::string(message);
  size_t cut = max_bytes >= 3 ? max_bytes - 3 : 0;
  // Back up to the start of a UTF-8 character (never inside 10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(message[cut]) & 0xC0) == 0x80) --cut;
  return absl::StrCat(message.substr(0, cut), "...");
}

}  // namespace lane
