// `lane backfill`'s manifest and shards (docs/backfill.md): the manifest read
// with bounds decided before anything is parsed, and each shard's share.
#ifndef LANE_TOOLS_BACKFILL_MANIFEST_H_
#define LANE_TOOLS_BACKFILL_MANIFEST_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace lane::cli {

// A manifest line: at most 64 KiB (a line is three paths and a name).
inline constexpr size_t kMaxManifestLineBytes = 64 * 1024;
// Nesting of a manifest line's JSON: the schema needs 1 (an object of
// strings); 4 leaves room for keys a later version may add (an object of
// small objects or arrays) without a parse of unbounded depth.
inline constexpr int kMaxManifestDepth = 4;
// The whole manifest: 256 MiB, over a million recordings of 200 bytes. It is
// refused by its size (fstat) before any of it is read.
inline constexpr int64_t kMaxManifestBytes = int64_t{256} << 20;

struct BackfillRecording {
  int line = 0;  // in the manifest, from 1
  std::string recording;
  std::string config;
  std::string output;
  uintmax_t bytes = 0;  // the recording's size on disk, the shards' balance
};

// The manifest's recordings, or INVALID_ARGUMENT with the reason (and
// "PATH:LINE: " for a line's fault): the manifest is not a regular file (a
// FIFO, a device, a /proc file: opened without blocking and refused), is
// over kMaxManifestBytes, has a line over kMaxManifestLineBytes or nested
// deeper than kMaxManifestDepth (both found before the line is parsed), a
// line that is not a JSON object with the three keys, a bad or repeated
// output name, or no recording. `with_sizes`: each recording is expanded
// (io/inputs.h, nothing is opened) to sum its files' sizes.
absl::StatusOr<std::vector<BackfillRecording>> ReadBackfillManifest(const std::string& path,
                                                                    bool with_sizes);

// The deepest nesting of '[' and '{' in a JSON text, strings (and their
// escapes) skipped: 0 for a scalar, 1 for {"a": "b"}. A scan of the raw
// bytes, so the bound is checked before a parser builds anything.
int JsonNestingDepth(std::string_view text);

// --shard I/N.
struct ShardSpec {
  int index = 0;
  int count = 1;
};

// "I/N" with 0 <= I < N (decimal, each fits an int), or INVALID_ARGUMENT.
absl::StatusOr<ShardSpec> ParseShardSpec(const std::string& text);

// Shard I of N's recordings: the largest first, each to the shard with the
// least bytes so far (ties: the lower shard; equal sizes: manifest order).
// Every shard computes the same assignment, so any one can run alone. Only
// the first min(N, recordings) shards ever get one (an empty shard has the
// least load, and the lowest such is taken), so a shard I beyond the
// manifest's length has an empty share, found without any O(N) work or
// memory: the assignment costs O(M log M) for M recordings, whatever N is.
std::vector<BackfillRecording> ShareOfShard(const std::vector<BackfillRecording>& all,
                                            ShardSpec shard);

}  // namespace lane::cli

#endif  // LANE_TOOLS_BACKFILL_MANIFEST_H_
