// A deliberate data race that the TSan step must find (scripts/sanitize.sh
// runs this and fails unless TSan reports it). It proves that the
// suppressions (tsan.supp) and the absl::Mutex model (tsan_absl_sync.cc) do
// not hide a race in our code between a gRPC callback thread and a worker of
// our pool: the same shape as a reactor and its frames' tasks.
//
// A unary GetServerInfo handler (callback API, on a gRPC thread) hands a task
// to a lane::server::WorkerPool and then writes g_unguarded; the task writes
// g_unguarded too. Neither write is ordered with the other.
//
// Exit: TSan's exit code (66) when it reported the race; 0 means it did not.
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <thread>

#include "lane/v1/lane_service.grpc.pb.h"
#include "worker_pool.h"

// External linkage and read at the end, so that the writes are not
// optimised away.
int g_unguarded = 0;

namespace {

__attribute__((noinline)) void CanaryWriteOnWorker() { g_unguarded = 1; }
__attribute__((noinline)) void CanaryWriteOnGrpcThread() { g_unguarded = 2; }

class CanaryService final : public lane::v1::LaneService::CallbackService {
 public:
  explicit CanaryService(lane::server::WorkerPool& pool) : pool_(pool) {}

  grpc::ServerUnaryReactor* GetServerInfo(grpc::CallbackServerContext* context,
                                          const lane::v1::GetServerInfoRequest* /*request*/,
                                          lane::v1::ServerInfo* /*response*/) override {
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    pool_.Submit([reactor] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      CanaryWriteOnWorker();
      reactor->Finish(grpc::Status::OK);
    });
    CanaryWriteOnGrpcThread();
    return reactor;
  }

 private:
  lane::server::WorkerPool& pool_;
};

}  // namespace

int main() {
  lane::server::WorkerPool pool(lane::server::WorkerPool::Options{1, 16});
  CanaryService service(pool);
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    std::fprintf(stderr, "tsan_canary: the server did not start\n");
    return 1;
  }
  auto stub = lane::v1::LaneService::NewStub(
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  lane::v1::ServerInfo info;
  const grpc::Status status =
      stub->GetServerInfo(&context, lane::v1::GetServerInfoRequest(), &info);
  server->Shutdown();
  pool.Shutdown();
  if (!status.ok()) {
    std::fprintf(stderr, "tsan_canary: the call failed: %s\n", status.error_message().c_str());
    return 1;
  }
  std::fprintf(stderr, "tsan_canary: the racing call completed (last write: %d)\n", g_unguarded);
  return 0;
}
