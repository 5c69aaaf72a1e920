#include "stereo/image_io.hpp"

#include <dlfcn.h>
#include <jpeglib.h>
#include <jerror.h>
#include <png.h>

#include <opencv2/imgcodecs.hpp>  // the IMREAD_ and IMWRITE_ flags only: no imgcodecs symbol is used here

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "pipeline/module.hpp"
#include "stereo/image_codecs_module.hpp"

namespace hedgefit::stereo {
namespace {

// ---- PNG through libpng, as OpenCV 4.6's PngDecoder / PngEncoder set it up ----

struct PngSource {
  const unsigned char* data;
  std::size_t size, at;
};

// What libpng's error handler longjmps with. It lives in the caller's frame, as does everything
// the decoder allocates before a longjmp may leave it (the row pointers).
struct PngErrors {
  std::jmp_buf jump;
  char message[256];
  png_bytep* rows = nullptr;
  ~PngErrors() { std::free(rows); }
};

void PngError(png_structp png, png_const_charp message) {
  auto* e = static_cast<PngErrors*>(png_get_error_ptr(png));
  std::snprintf(e->message, sizeof(e->message), "%s", message);
  std::longjmp(e->jump, 1);
}

void PngWarning(png_structp, png_const_charp) {}  // libpng's warnings would print on stderr

void PngRead(png_structp png, png_bytep out, png_size_t n) {
  auto* s = static_cast<PngSource*>(png_get_io_ptr(png));
  if (n > s->size - s->at) png_error(png, "the file ends before its image data does");
  std::memcpy(out, s->data + s->at, n);
  s->at += n;
}

// Nothing with a destructor lives in the frames libpng's longjmp leaves.
struct PngLayout {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0, channels = 0;
  bool sixteen = false;
};

// Returns true on success; on failure `errors.message` says why.
bool PngDecode(PngSource* src, int flags, PngErrors* errors, cv::Mat* out) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, errors, PngError, PngWarning);
  if (png == nullptr) return std::snprintf(errors->message, sizeof(errors->message), "out of memory"), false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(errors->jump) != 0) {
    png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    return false;
  }
  png_set_read_fn(png, src, PngRead);
  png_read_info(png, info);
  PngLayout l;
  png_get_IHDR(png, info, &l.width, &l.height, &l.bit_depth, &l.color_type, nullptr, nullptr, nullptr);
  const bool has_alpha = (l.color_type & PNG_COLOR_MASK_ALPHA) != 0 || png_get_valid(png, info, PNG_INFO_tRNS);
  const bool is_colour = (l.color_type & PNG_COLOR_MASK_COLOR) != 0;
  if (flags == cv::IMREAD_UNCHANGED) {
    l.channels = (is_colour ? 3 : 1) + (has_alpha ? 1 : 0);
    l.sixteen = l.bit_depth == 16;
  } else {
    l.channels = flags == cv::IMREAD_GRAYSCALE ? 1 : 3;
  }
  if (static_cast<double>(l.width) * l.height > double(1 << 30)) png_error(png, "more than 2^30 pixels");
  const int type = CV_MAKETYPE(l.sixteen ? CV_16U : CV_8U, l.channels);
  out->create(int(l.height), int(l.width), type);
  if (l.bit_depth == 16) {
    if (l.sixteen) {
      png_set_swap(png);  // to the machine's byte order
    } else {
      png_set_strip_16(png);
    }
  }
  if (l.channels == 4 || l.channels == 2) {
    png_set_tRNS_to_alpha(png);
  } else {
    png_set_strip_alpha(png);
  }
  if (l.color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (!is_colour && l.bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (is_colour && l.channels >= 3) {
    png_set_bgr(png);
  } else if (l.channels >= 3) {
    png_set_gray_to_rgb(png);
  } else if (is_colour) {
    png_set_rgb_to_gray(png, 1, 0.299, 0.587);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != out->cols * out->elemSize()) png_error(png, "an unexpected pixel layout");
  errors->rows = static_cast<png_bytep*>(std::malloc(sizeof(png_bytep) * l.height));
  if (errors->rows == nullptr) png_error(png, "out of memory");
  for (png_uint_32 y = 0; y < l.height; ++y) errors->rows[y] = out->ptr<png_byte>(int(y));
  png_read_image(png, errors->rows);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

void PngWriteBytes(png_structp png, png_bytep data, png_size_t n) {
  auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + n);
}

void PngFlush(png_structp) {}

bool PngEncode(const cv::Mat& image, std::vector<unsigned char>* bytes, PngErrors* errors) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, errors, PngError, PngWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(errors->jump) != 0) {
    png_destroy_write_struct(&png, info ? &info : nullptr);
    return false;
  }
  png_set_write_fn(png, bytes, PngWriteBytes, PngFlush);
  png_set_compression_level(png, 1);  // OpenCV's imencode default: fast, larger files
  const int channels = image.channels();
  const int color_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                         : channels == 3 ? PNG_COLOR_TYPE_RGB
                                         : PNG_COLOR_TYPE_RGB_ALPHA;
  png_set_IHDR(png, info, png_uint_32(image.cols), png_uint_32(image.rows), image.depth() == CV_16U ? 16 : 8,
               color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  if (channels >= 3) png_set_bgr(png);
  if (image.depth() == CV_16U) png_set_swap(png);
  for (int y = 0; y < image.rows; ++y) png_write_row(png, const_cast<png_bytep>(image.ptr<png_byte>(y)));
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

// ---- JPEG through libjpeg(-turbo), as OpenCV 4.6's JpegDecoder / JpegEncoder ----

// What libjpeg's error handler longjmps with, and the encoder's output buffer (which libjpeg
// grows behind our back), in the caller's frame.
struct JpegErrors {
  jpeg_error_mgr base;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  ~JpegErrors() { std::free(buffer); }
};

void JpegError(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegErrors*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

// A stream cut short, which libjpeg would only warn about and patch over with grey, is an error;
// other warnings (stray bytes before a marker, which some cameras write) are not.
void JpegWarning(j_common_ptr cinfo, int level) {
  if (level < 0 && cinfo->err->msg_code == JWRN_JPEG_EOF) JpegError(cinfo);
}

bool JpegDecode(const std::vector<unsigned char>& bytes, int flags, JpegErrors* errors, cv::Mat* out) {
  jpeg_decompress_struct cinfo;
  cinfo.err = jpeg_std_error(&errors->base);
  errors->base.error_exit = JpegError;
  errors->base.emit_message = JpegWarning;
  jpeg_create_decompress(&cinfo);
  if (setjmp(errors->jump) != 0) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  jpeg_mem_src(&cinfo, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&cinfo, TRUE);
  const bool grey = flags == cv::IMREAD_GRAYSCALE || (flags == cv::IMREAD_UNCHANGED && cinfo.num_components == 1);
  if (cinfo.num_components == 4) {
    std::snprintf(errors->message, sizeof(errors->message), "a CMYK JPEG; give an RGB or grey one");
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  cinfo.out_color_space = grey ? JCS_GRAYSCALE : JCS_EXT_BGR;
  cinfo.out_color_components = grey ? 1 : 3;
  jpeg_start_decompress(&cinfo);
  if (static_cast<double>(cinfo.output_width) * cinfo.output_height > double(1 << 30)) {
    std::snprintf(errors->message, sizeof(errors->message), "more than 2^30 pixels");
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  out->create(int(cinfo.output_height), int(cinfo.output_width), grey ? CV_8UC1 : CV_8UC3);
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = out->ptr<JSAMPLE>(int(cinfo.output_scanline));
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

bool JpegEncode(const cv::Mat& image, int quality, std::vector<unsigned char>* bytes, JpegErrors* errors) {
  jpeg_compress_struct cinfo;
  cinfo.err = jpeg_std_error(&errors->base);
  errors->base.error_exit = JpegError;
  jpeg_create_compress(&cinfo);
  if (setjmp(errors->jump) != 0) {
    jpeg_destroy_compress(&cinfo);
    return false;
  }
  jpeg_mem_dest(&cinfo, &errors->buffer, &errors->size);
  cinfo.image_width = JDIMENSION(image.cols);
  cinfo.image_height = JDIMENSION(image.rows);
  cinfo.input_components = image.channels();
  cinfo.in_color_space = image.channels() == 1 ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, std::clamp(quality, 0, 100), TRUE);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(image.ptr<JSAMPLE>(int(cinfo.next_scanline)));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  bytes->assign(errors->buffer, errors->buffer + errors->size);
  return true;
}

// ---- Every other format: OpenCV's imgcodecs, in a module loaded on first use ----

struct CodecModule {
  ImageReadFn read = nullptr;
  ImageEncodeFn encode = nullptr;
  std::string why;
};

// Loaded once and never unloaded (pipeline::OpenOwnModule).
const CodecModule& Codecs() {
  static std::once_flag once;
  static CodecModule m;
  std::call_once(once, [] {
    const char* name = "libhedgefit_imgcodecs.so";
    void* handle = pipeline::OpenOwnModule(name, reinterpret_cast<const void*>(&SniffImageFormat), &m.why);
    if (handle == nullptr) return;
    m.read = reinterpret_cast<ImageReadFn>(dlsym(handle, HEDGEFIT_IMAGE_READ_SYMBOL));
    m.encode = reinterpret_cast<ImageEncodeFn>(dlsym(handle, HEDGEFIT_IMAGE_ENCODE_SYMBOL));
    if (m.read == nullptr || m.encode == nullptr) m.why = std::string(name) + " lacks its entry points";
  });
  return m;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

}  // namespace

std::string SniffImageFormat(const unsigned char* m, std::size_t n) {
  if (n >= 4 && m[0] == 0x89 && m[1] == 'P' && m[2] == 'N' && m[3] == 'G') return "png";
  if (n >= 3 && m[0] == 0xFF && m[1] == 0xD8 && m[2] == 0xFF) return "jpeg";
  if (n >= 4 && ((m[0] == 'I' && m[1] == 'I' && m[2] == 42 && m[3] == 0) || (m[0] == 'M' && m[1] == 'M' && m[2] == 0 && m[3] == 42))) {
    return "tiff";
  }
  if (n >= 2 && m[0] == 'B' && m[1] == 'M') return "bmp";
  if (n >= 2 && m[0] == 'P' && (m[1] == 'f' || m[1] == 'F')) return "pfm";
  if (n >= 2 && m[0] == 'P' && m[1] >= '1' && m[1] <= '6') return "pnm";
  return "";
}

cv::Mat DecodeImage(const std::vector<unsigned char>& bytes, int flags, const std::string& name) {
  if (flags != cv::IMREAD_COLOR && flags != cv::IMREAD_GRAYSCALE && flags != cv::IMREAD_UNCHANGED) {
    throw Error(name + ": DecodeImage reads colour, grey or unchanged images only");
  }
  const std::string format = SniffImageFormat(bytes.data(), bytes.size());
  cv::Mat out;
  if (format == "png") {
    PngSource src{bytes.data(), bytes.size(), 0};
    PngErrors errors{};
    if (!PngDecode(&src, flags, &errors, &out)) throw Error(name + ": cannot decode the PNG (" + errors.message + ")");
    return out;
  }
  if (format == "jpeg") {
    JpegErrors errors{};
    if (!JpegDecode(bytes, flags, &errors, &out)) throw Error(name + ": cannot decode the JPEG (" + errors.message + ")");
    return out;
  }
  if (format.empty()) throw Error(name + ": not a PNG, JPEG, TIFF, BMP, PNM or PFM image");
  const CodecModule& m = Codecs();
  if (m.read == nullptr) {
    throw Error(name + ": " + format + " images need hedgefit's image module, which cannot be loaded (" + m.why +
                "); reinstall hedgefit, or convert the image to PNG");
  }
  char why[256] = {0};
  if (m.read(bytes.data(), bytes.size(), flags, &out, why, sizeof(why)) != 0) {
    throw Error(name + ": cannot read the " + format + " image (" + why + ")");
  }
  return out;
}

std::vector<unsigned char> ReadFileBytes(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory; give the image file in it");
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": no such image file; check the path");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error(path + ": cannot open the image; check the path and permissions");
  const std::streamoff size = in.tellg();
  std::vector<unsigned char> bytes(static_cast<std::size_t>(std::max<std::streamoff>(0, size)));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()))) {
    throw Error(path + ": cannot read the image; check the file");
  }
  return bytes;
}

cv::Mat ReadImageFile(const std::string& path, int flags) { return DecodeImage(ReadFileBytes(path), flags, path); }

bool EncodeImage(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>* bytes,
                 int jpeg_quality) {
  bytes->clear();
  if (image.empty() || image.dims != 2) return false;
  const std::string ext = Lower(extension);
  const int channels = image.channels();
  if (ext == ".png") {
    if ((image.depth() != CV_8U && image.depth() != CV_16U) || channels == 2 || channels > 4) return false;
    PngErrors errors{};
    return PngEncode(image, bytes, &errors);
  }
  if (ext == ".jpg" || ext == ".jpeg") {
    if (image.depth() != CV_8U || (channels != 1 && channels != 3)) return false;
    JpegErrors errors{};
    return JpegEncode(image, jpeg_quality, bytes, &errors);
  }
  const CodecModule& m = Codecs();
  return m.encode != nullptr && m.encode(ext.c_str(), &image, bytes) == 0;
}

void WriteImageAtomic(const std::string& path, const cv::Mat& image) {
  const std::string ext = std::filesystem::path(path).extension().string();
  std::vector<unsigned char> bytes;
  if (ext.empty() || !EncodeImage(ext, image, &bytes)) {
    throw Error(path + ": cannot encode the image as '" + ext + "'; give a .png or .jpg file name");
  }
  cloud::WriteTextFileAtomic(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace hedgefit::stereo
