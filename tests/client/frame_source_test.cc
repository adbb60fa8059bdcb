// lane-client's frames from files (client/frames.h): a file that is not a
// regular file, or too large, is that frame's error; the frames after it are
// read, and nothing blocks or reads without bound.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "frames.h"

namespace lane::client {
namespace {

namespace fs = std::filesystem;

TEST(FrameSourceTest, HostileFilesAreTheirFramesErrorsAndTheNextFrameIsRead) {
  const fs::path dir =
      fs::temp_directory_path() / ("frame_source_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string fifo = (dir / "fifo.jpg").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // A sparse file over the 64 MiB image cap: refused before it is read.
  const std::string huge = (dir / "huge.jpg").string();
  {
    std::ofstream out(huge, std::ios::binary);
    out.seekp((int64_t{128} << 20) - 1);
    out.put('\0');
  }
  // A real JPEG header after them (SOI + garbage): read and sent as encoded.
  const std::string good = (dir / "good.jpg").string();
  {
    std::ofstream out(good, std::ios::binary);
    out << "\xFF\xD8\xFF\xE0 not a whole jpeg";
  }
  const auto start = std::chrono::steady_clock::now();
  FrameSource source({"/dev/zero", "/proc/self/mem", fifo, huge, good}, /*raw=*/false);
  std::vector<ClientFrame> frames;
  ClientFrame frame;
  while (source.Next(&frame)) {
    frames.push_back(frame);
    frame = ClientFrame();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 5.0) << "reading must neither block nor read without bound";
  ASSERT_EQ(frames.size(), 5u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_FALSE(frames[i].error.empty()) << frames[i].name;
    EXPECT_TRUE(frames[i].encoded.empty()) << frames[i].name;
  }
  EXPECT_NE(frames[2].error.find("FIFO"), std::string::npos) << frames[2].error;
  EXPECT_TRUE(frames[4].error.empty()) << frames[4].error;
  EXPECT_FALSE(frames[4].encoded.empty());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lane::client
