// libhedgefit_imgcodecs.so: OpenCV's imgcodecs for the image formats hedgefit does not decode
// itself (TIFF, BMP, PNM, PFM), loaded by stereo/image_io.cpp only when such a file is met.

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <exception>

#include "stereo/image_codecs_module.hpp"

extern "C" int hedgefit_image_read_v1(const unsigned char* bytes, std::size_t size, int flags, cv::Mat* out,
                                      char* why, std::size_t why_size) {
  try {
    const cv::Mat buffer(1, int(size), CV_8U, const_cast<unsigned char*>(bytes));
    *out = cv::imdecode(buffer, flags);
    if (out->empty()) {
      std::snprintf(why, why_size, "damaged, cut short, or a variant OpenCV does not read");
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    const auto* cv_error = dynamic_cast<const cv::Exception*>(&e);
    std::snprintf(why, why_size, "%s", cv_error ? cv_error->err.c_str() : e.what());
    return 1;
  }
}

extern "C" int hedgefit_image_encode_v1(const char* extension, const cv::Mat* image, std::vector<unsigned char>* out) {
  try {
    return cv::imencode(extension, *image, *out) ? 0 : 1;
  } catch (const std::exception&) {
    return 1;
  }
}
