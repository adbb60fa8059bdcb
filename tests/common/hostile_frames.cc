#include "hostile_frames.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <csetjmp>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace lane::testing {

// ---- Frames -----------------------------------------------------------------

// A colour gradient with noise: smooth regions and texture, as a road scene.
cv::Mat Frame(int width, int height, uint64_t seed) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uchar>(x * 255 / width), static_cast<uchar>(y * 255 / height),
                    static_cast<uchar>((x + y) * 127 / (width + height)));
    }
  }
  cv::Mat noise(height, width, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 48);
  cv::add(image, noise, image);
  return image;
}

cv::Mat GreyFrame(int width, int height, uint64_t seed) {
  cv::Mat grey;
  cv::cvtColor(Frame(width, height, seed), grey, cv::COLOR_BGR2GRAY);
  return grey;
}

std::string Encode(const cv::Mat& image, const std::string& ext, const std::vector<int>& params) {
  std::vector<uchar> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes, params));
  return std::string(bytes.begin(), bytes.end());
}

std::string Jpeg(const cv::Mat& image, int quality, bool progressive) {
  return Encode(image, ".jpg",
                {cv::IMWRITE_JPEG_QUALITY, quality, cv::IMWRITE_JPEG_PROGRESSIVE, progressive});
}

// ---- JPEG structure ---------------------------------------------------------

std::vector<JpegSegment> JpegSegments(const std::string& jpeg) {
  const auto* d = reinterpret_cast<const unsigned char*>(jpeg.data());
  const size_t n = jpeg.size();
  std::vector<JpegSegment> segments;
  size_t pos = 2;
  while (pos + 1 < n && d[pos] == 0xFF) {
    JpegSegment s;
    s.begin = pos;
    while (pos < n && d[pos] == 0xFF) ++pos;
    if (pos >= n) break;
    s.marker = d[pos++];
    if (s.marker == 0xD9) {
      s.end = pos;
      segments.push_back(s);
      break;
    }
    if (pos + 2 > n) break;
    pos += (size_t{d[pos]} << 8) | d[pos + 1];
    if (s.marker == 0xDA) {
      // Entropy-coded data up to the next marker other than a stuffed 0x00
      // or a restart marker.
      while (pos + 1 < n &&
             !(d[pos] == 0xFF && d[pos + 1] != 0x00 && (d[pos + 1] < 0xD0 || d[pos + 1] > 0xD7))) {
        ++pos;
      }
    }
    s.end = pos;
    segments.push_back(s);
  }
  return segments;
}

int CountScans(const std::string& jpeg) {
  int scans = 0;
  for (const JpegSegment& s : JpegSegments(jpeg)) scans += s.marker == 0xDA;
  return scans;
}

// ---- libjpeg encoder with a scan script (for files cv::imencode cannot make) --

struct EncodeJob {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr error;
  std::jmp_buf jump;
  const unsigned char* pixels;  // interleaved, width * components per row
  int width;
  int height;
  int components;
  J_COLOR_SPACE in_color_space;
  J_COLOR_SPACE file_color_space;  // JCS_UNKNOWN: libjpeg's default for the input
  const jpeg_scan_info* scans;     // null: libjpeg's default (baseline)
  int quality;
  bool full_chroma;  // 4:4:4 instead of libjpeg's default 4:2:0
  int luma_h;        // luma sampling factors; 0: libjpeg's default
  int luma_v;
  bool progressive;  // libjpeg's standard progression (scans == null only)
  int restart_rows;
  int num_scans;
  unsigned char* out;  // malloc'ed by jpeg_mem_dest
  unsigned long out_size;
};

[[noreturn]] void OnEncodeError(j_common_ptr cinfo) {
  std::longjmp(static_cast<EncodeJob*>(cinfo->client_data)->jump, 1);
}

void OnEncodeMessage(j_common_ptr /*cinfo*/) {}

bool RunEncode(EncodeJob* job) {
  job->cinfo.err = jpeg_std_error(&job->error);
  job->error.error_exit = OnEncodeError;
  job->error.output_message = OnEncodeMessage;
  job->cinfo.client_data = job;
  if (setjmp(job->jump) != 0) {
    jpeg_destroy_compress(&job->cinfo);
    return false;
  }
  jpeg_create_compress(&job->cinfo);
  jpeg_mem_dest(&job->cinfo, &job->out, &job->out_size);
  job->cinfo.image_width = static_cast<JDIMENSION>(job->width);
  job->cinfo.image_height = static_cast<JDIMENSION>(job->height);
  job->cinfo.input_components = job->components;
  job->cinfo.in_color_space = job->in_color_space;
  jpeg_set_defaults(&job->cinfo);
  jpeg_set_quality(&job->cinfo, job->quality, TRUE);
  if (job->full_chroma) {
    job->cinfo.comp_info[0].h_samp_factor = 1;
    job->cinfo.comp_info[0].v_samp_factor = 1;
  }
  if (job->luma_h != 0 && job->components == 3) {
    job->cinfo.comp_info[0].h_samp_factor = job->luma_h;
    job->cinfo.comp_info[0].v_samp_factor = job->luma_v;
  }
  if (job->file_color_space != JCS_UNKNOWN) jpeg_set_colorspace(&job->cinfo, job->file_color_space);
  if (job->scans != nullptr) {
    job->cinfo.scan_info = job->scans;
    job->cinfo.num_scans = job->num_scans;
  } else if (job->progressive) {
    jpeg_simple_progression(&job->cinfo);
  }
  job->cinfo.restart_in_rows = job->restart_rows;
  jpeg_start_compress(&job->cinfo, TRUE);
  while (job->cinfo.next_scanline < job->cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(job->pixels) +
                   size_t{job->cinfo.next_scanline} * job->width * job->components;
    jpeg_write_scanlines(&job->cinfo, &row, 1);
  }
  jpeg_finish_compress(&job->cinfo);
  jpeg_destroy_compress(&job->cinfo);
  return true;
}

std::string LibjpegEncode(const cv::Mat& pixels, J_COLOR_SPACE in_color_space,
                          const std::vector<jpeg_scan_info>& scans, J_COLOR_SPACE file_color_space,
                          int quality, bool full_chroma) {
  EXPECT_TRUE(pixels.isContinuous());
  EncodeJob job{};
  job.pixels = pixels.data;
  job.width = pixels.cols;
  job.height = pixels.rows;
  job.components = pixels.channels();
  job.in_color_space = in_color_space;
  job.file_color_space = file_color_space;
  job.scans = scans.empty() ? nullptr : scans.data();
  job.num_scans = static_cast<int>(scans.size());
  job.quality = quality;
  job.full_chroma = full_chroma;
  const bool ok = RunEncode(&job);
  EXPECT_TRUE(ok) << "libjpeg could not encode";
  std::string bytes = ok ? std::string(reinterpret_cast<char*>(job.out), job.out_size) : "";
  std::free(job.out);
  return bytes;
}

std::string LibjpegEncodeLayout(const cv::Mat& image, const JpegLayout& layout) {
  EXPECT_TRUE(image.isContinuous());
  EXPECT_TRUE(image.type() == CV_8UC3 || image.type() == CV_8UC1);
  EncodeJob job{};
  job.pixels = image.data;
  job.width = image.cols;
  job.height = image.rows;
  job.components = image.channels();
  job.in_color_space = image.channels() == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
  job.file_color_space = JCS_UNKNOWN;
  job.quality = layout.quality;
  job.luma_h = layout.luma_h;
  job.luma_v = layout.luma_v;
  job.progressive = layout.progressive;
  job.restart_rows = layout.restart_rows;
  const bool ok = RunEncode(&job);
  EXPECT_TRUE(ok) << "libjpeg could not encode";
  std::string bytes = ok ? std::string(reinterpret_cast<char*>(job.out), job.out_size) : "";
  std::free(job.out);
  return bytes;
}

jpeg_scan_info Scan(std::initializer_list<int> components, int ss, int se, int ah, int al) {
  jpeg_scan_info scan{};
  scan.comps_in_scan = static_cast<int>(components.size());
  int i = 0;
  for (int c : components) scan.component_index[i++] = c;
  scan.Ss = ss;
  scan.Se = se;
  scan.Ah = ah;
  scan.Al = al;
  return scan;
}

// A valid progression with 2090 scans: the DC of all components, then every
// AC coefficient of every component on its own, each sent from bit 10 down
// to bit 0 one bit per scan (libjpeg's most successive approximation for
// 8-bit data). Every scan is legitimate, libjpeg warns about none.
std::vector<jpeg_scan_info> ManyScansScript() {
  constexpr int kTopBit = 10;
  std::vector<jpeg_scan_info> scans;
  scans.push_back(Scan({0, 1, 2}, 0, 0, 0, kTopBit));
  for (int bit = kTopBit; bit > 0; --bit) scans.push_back(Scan({0, 1, 2}, 0, 0, bit, bit - 1));
  for (int c = 0; c < 3; ++c) {
    for (int k = 1; k < 64; ++k) {
      scans.push_back(Scan({c}, k, k, 0, kTopBit));
      for (int bit = kTopBit; bit > 0; --bit) scans.push_back(Scan({c}, k, k, bit, bit - 1));
    }
  }
  return scans;
}

// ---- libpng writer (interlaced and other kinds cv::imencode cannot make) ------

struct WriteJob {
  const PngImage* image;
  png_bytep* row_pointers;
  std::string* out;
};

void AppendPng(png_structp png, png_bytep data, size_t size) {
  static_cast<WriteJob*>(png_get_io_ptr(png))->out->append(reinterpret_cast<char*>(data), size);
}

void FlushPng(png_structp /*png*/) {}

bool RunPngWrite(WriteJob* job) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  const PngImage& image = *job->image;
  png_set_write_fn(png, job, AppendPng, FlushPng);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width),
               static_cast<png_uint_32>(image.height), image.bit_depth, image.color_type,
               image.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (!image.palette.empty()) {
    png_set_PLTE(png, info, image.palette.data(), static_cast<int>(image.palette.size()));
  }
  if (!image.palette_alpha.empty()) {
    png_set_tRNS(png, info, image.palette_alpha.data(),
                 static_cast<int>(image.palette_alpha.size()), nullptr);
  }
  if (image.gamma != 0) png_set_gAMA_fixed(png, info, image.gamma);
  if (image.srgb) png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  png_write_image(png, job->row_pointers);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

std::string WritePng(PngImage image) {
  std::vector<png_bytep> pointers;
  for (auto& row : image.rows) pointers.push_back(row.data());
  std::string out;
  WriteJob job{&image, pointers.data(), &out};
  EXPECT_TRUE(RunPngWrite(&job)) << "libpng could not write";
  return out;
}

// `bgr` (CV_8UC3) or grey (CV_8UC1) as an 8-bit PNG, optionally interlaced.
PngImage PngOf(const cv::Mat& image, bool interlaced) {
  PngImage png;
  png.width = image.cols;
  png.height = image.rows;
  png.color_type = image.channels() == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY;
  png.interlaced = interlaced;
  cv::Mat rgb;
  if (image.channels() == 3) {
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  } else {
    rgb = image;
  }
  for (int y = 0; y < image.rows; ++y) {
    png.rows.emplace_back(rgb.ptr(y), rgb.ptr(y) + rgb.cols * rgb.channels());
  }
  return png;
}

// ---- PNG chunks by hand (for bombs and damage) --------------------------------

void PutBigEndian32(std::string& out, uint32_t v) {
  out.push_back(static_cast<char>(v >> 24));
  out.push_back(static_cast<char>(v >> 16));
  out.push_back(static_cast<char>(v >> 8));
  out.push_back(static_cast<char>(v));
}

void PutChunk(std::string& out, const char type[5], const std::string& data) {
  PutBigEndian32(out, static_cast<uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  out += body;
  PutBigEndian32(out, static_cast<uint32_t>(
                          crc32(0, reinterpret_cast<const Bytef*>(body.data()), body.size())));
}

// Appends everything deflate produces for `input` with `flush`.
void Deflate(z_stream& stream, const unsigned char* input, size_t size, int flush,
             std::string& out) {
  stream.next_in = const_cast<Bytef*>(input);
  stream.avail_in = static_cast<uInt>(size);
  unsigned char buffer[1 << 16];
  do {
    stream.next_out = buffer;
    stream.avail_out = sizeof buffer;
    const int result = deflate(&stream, flush);
    ASSERT_TRUE(result == Z_OK || result == Z_STREAM_END || result == Z_BUF_ERROR) << result;
    out.append(reinterpret_cast<char*>(buffer), sizeof buffer - stream.avail_out);
  } while (stream.avail_out == 0 || stream.avail_in > 0);
}

// A valid 8-bit RGB PNG of `bgr` whose zlib stream goes on, after the image's
// rows, with `extra_mib` MiB of zeros: what a decoder that inflates the whole
// stream pays for. The zeros are one 4 MiB deflate segment (self-contained:
// it starts and ends with a full flush) repeated, so building a GiB bomb
// costs nothing; the Adler-32 is computed over everything. Split into IDAT
// chunks of 64 KiB like an ordinary encoder's.
std::string PngBomb(const cv::Mat& bgr, int extra_mib) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  std::string raw;
  for (int y = 0; y < rgb.rows; ++y) {
    raw.push_back('\0');  // filter: none
    raw.append(reinterpret_cast<const char*>(rgb.ptr(y)), rgb.cols * 3);
  }
  z_stream stream{};
  EXPECT_EQ(deflateInit2(&stream, 9, Z_DEFLATED, -15, 9, Z_DEFAULT_STRATEGY), Z_OK);
  std::string zlib = "\x78\x9C";  // zlib header: deflate, 32 KiB window
  Deflate(stream, reinterpret_cast<const unsigned char*>(raw.data()), raw.size(), Z_FULL_FLUSH,
          zlib);
  uLong adler = adler32(1, reinterpret_cast<const Bytef*>(raw.data()), raw.size());
  constexpr int kSegmentMiB = 4;
  const std::vector<unsigned char> zeros(size_t{kSegmentMiB} << 20, 0);
  std::string segment;
  Deflate(stream, zeros.data(), zeros.size(), Z_FULL_FLUSH, segment);
  const uLong zeros_adler = adler32(1, zeros.data(), zeros.size());
  for (int i = 0; i < extra_mib / kSegmentMiB; ++i) {
    zlib += segment;
    adler = adler32_combine(adler, zeros_adler, static_cast<z_off_t>(zeros.size()));
  }
  Deflate(stream, nullptr, 0, Z_FINISH, zlib);  // the final (empty) block
  deflateEnd(&stream);
  PutBigEndian32(zlib, static_cast<uint32_t>(adler));

  std::string png("\x89PNG\r\n\x1A\n", 8);
  std::string ihdr;
  PutBigEndian32(ihdr, static_cast<uint32_t>(bgr.cols));
  PutBigEndian32(ihdr, static_cast<uint32_t>(bgr.rows));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit RGB, not interlaced
  PutChunk(png, "IHDR", ihdr);
  for (size_t pos = 0; pos < zlib.size(); pos += 1 << 16) {
    PutChunk(png, "IDAT", zlib.substr(pos, 1 << 16));
  }
  PutChunk(png, "IEND", "");
  return png;
}

// The attack: a progressive JPEG with one small refinement scan repeated
// before EOI until the file holds ~146,000 scans in 1.7 MB. The frame is
// grey in colour, so a chroma AC refinement scan is an SOS header and a
// single EOB run: ~12 bytes per scan, each a pass over the coefficients.
std::string RepeatedScanBomb(int repeats) {
  cv::Mat frame;
  cv::cvtColor(GreyFrame(640, 480), frame, cv::COLOR_GRAY2BGR);
  const std::string jpeg = Jpeg(frame, 95, true);
  const std::vector<JpegSegment> segments = JpegSegments(jpeg);
  const JpegSegment* smallest = nullptr;
  for (const JpegSegment& s : segments) {
    if (s.marker != 0xDA) continue;
    const unsigned char ns = static_cast<unsigned char>(jpeg[s.begin + 4]);
    const unsigned char ah_al = static_cast<unsigned char>(jpeg[s.begin + 5 + 2 * ns + 2]);
    if ((ah_al >> 4) == 0) continue;  // a first scan, not a refinement
    if (smallest == nullptr || s.end - s.begin < smallest->end - smallest->begin) smallest = &s;
  }
  EXPECT_NE(smallest, nullptr);
  if (smallest == nullptr) return jpeg;
  const std::string scan = jpeg.substr(smallest->begin, smallest->end - smallest->begin);
  EXPECT_LT(scan.size(), 32u);
  std::string bomb = jpeg.substr(0, jpeg.size() - 2);  // without EOI
  bomb.reserve(bomb.size() + scan.size() * static_cast<size_t>(repeats) + 2);
  for (int i = 0; i < repeats; ++i) bomb += scan;
  bomb += "\xFF\xD9";
  return bomb;
}

std::string PngDeclaring(const std::string& png, uint32_t width, uint32_t height) {
  std::string out = png;
  for (int i = 0; i < 4; ++i) {
    out[16 + i] = static_cast<char>((width >> (24 - 8 * i)) & 0xFF);
    out[20 + i] = static_cast<char>((height >> (24 - 8 * i)) & 0xFF);
  }
  return out;
}

std::string JpegDeclaring(const std::string& jpeg, uint16_t width, uint16_t height) {
  std::string out = jpeg;
  const size_t sof = out.find("\xFF\xC0");
  if (sof == std::string::npos) return out;
  out[sof + 5] = static_cast<char>(height >> 8);
  out[sof + 6] = static_cast<char>(height & 0xFF);
  out[sof + 7] = static_cast<char>(width >> 8);
  out[sof + 8] = static_cast<char>(width & 0xFF);
  return out;
}

}  // namespace lane::testing
