#include "raw_call.h"

#include <google/protobuf/stubs/logging.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include <cstdio>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "lane/base/excerpt.h"

namespace lane::server {
namespace {

// Protobuf reports why a parse failed (for example a string field that is
// not UTF-8) only to its log. While a thread parses a request, its log
// messages are caught here for the status instead of reaching stderr, where a
// client could flood the server's log with them. Other messages go on to
// protobuf's previous handler.
thread_local std::string* t_parse_log = nullptr;
google::protobuf::LogHandler* g_previous_handler = nullptr;

void CatchParseLog(google::protobuf::LogLevel level, const char* filename, int line,
                   const std::string& message) {
  if (t_parse_log != nullptr) {
    if (t_parse_log->empty()) *t_parse_log = message;
    return;
  }
  if (g_previous_handler != nullptr) g_previous_handler(level, filename, line, message);
}

void InstallLogCatcher() {
  static std::once_flag once;
  std::call_once(once,
                 [] { g_previous_handler = google::protobuf::SetLogHandler(&CatchParseLog); });
}

// "String field 'lane.v1.FrameRequest.camera_id' contains invalid UTF-8 data
// when parsing a protocol buffer. Use the 'bytes' type ..." -> its first
// sentence, which says what is wrong; the rest is advice to the proto's author.
std::string FirstSentence(const std::string& text) {
  const size_t end = text.find(". ");
  return end == std::string::npos ? text : text.substr(0, end);
}

}  // namespace

absl::Status ParseMessage(grpc::ByteBuffer& bytes, google::protobuf::Message* message) {
  InstallLogCatcher();
  const size_t size = bytes.Length();
  std::string log;
  bool parsed = false;
  {
    grpc::ProtoBufferReader reader(&bytes);
    if (reader.status().ok()) {
      t_parse_log = &log;
      parsed = message->ParseFromZeroCopyStream(&reader);
      t_parse_log = nullptr;
    }
  }
  bytes.Clear();
  if (parsed) return absl::OkStatus();
  const std::string type = message->GetDescriptor()->full_name();
  if (log.empty()) {
    return wire::InvalidRequest(absl::StrCat("the request (", size, " bytes) is not a valid ", type,
                                             " message: malformed protobuf"));
  }
  return wire::InvalidRequest(absl::StrCat("the request (", size, " bytes) is not a valid ", type,
                                           " message: ", lane::Excerpt(FirstSentence(log), 200)));
}

absl::Status SerializeMessage(const google::protobuf::Message& message, grpc::ByteBuffer* out) {
  bool own_buffer = false;
  const grpc::Status status =
      grpc::SerializationTraits<google::protobuf::Message>::Serialize(message, out, &own_buffer);
  if (!status.ok()) {
    return absl::InternalError(
        absl::StrCat("cannot serialize the response: ", status.error_message()));
  }
  return absl::OkStatus();
}

}  // namespace lane::server
