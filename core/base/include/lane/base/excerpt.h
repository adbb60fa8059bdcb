// Quoting input we did not write (a camera id, a config key, a value) in an
// error message: a short, escaped excerpt, never the whole of it. Messages
// travel in gRPC status metadata, which a default client refuses beyond about
// 8 kB, and end up in logs; an excerpt keeps them short and printable.
#ifndef LANE_EXCERPT_H_
#define LANE_EXCERPT_H_

#include <cstddef>
#include <string>

#include "absl/strings/string_view.h"

namespace lane {

// Characters of input quoted by Excerpt by default.
inline constexpr size_t kExcerptChars = 48;

// `text` with printable ASCII kept and everything else escaped (\n, \t, \",
// \\, \xNN), cut after `max_chars` input characters with a note of the total
// length: `abc...` (10000 bytes)`. Never longer than about 4 * max_chars + 24.
std::string Excerpt(absl::string_view text, size_t max_chars = kExcerptChars);

// The same in double quotes: "abc".
std::string QuotedExcerpt(absl::string_view text, size_t max_chars = kExcerptChars);

// `message` cut to at most `max_bytes` bytes (at a UTF-8 character boundary),
// ending in "..." when cut. For messages built from several excerpts.
std::string CapMessage(absl::string_view message, size_t max_bytes);

}  // namespace lane

#endif  // LANE_EXCERPT_H_
