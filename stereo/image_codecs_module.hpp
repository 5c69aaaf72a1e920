#pragma once
/// The entry points of libhedgefit_imgcodecs.so, the module that reads and encodes the image
/// formats stereo/image_io.cpp does not decode itself, through OpenCV's imgcodecs.

#include <opencv2/core.hpp>

#include <cstddef>
#include <vector>

#define HEDGEFIT_IMAGE_READ_SYMBOL "hedgefit_image_read_v1"
#define HEDGEFIT_IMAGE_ENCODE_SYMBOL "hedgefit_image_encode_v1"

namespace hedgefit::stereo {

/// Decodes `size` bytes with cv::imdecode(`flags`) into `out`; 0 on success, else non-zero and
/// why in `why` (at most `why_size` bytes, NUL-terminated).
using ImageReadFn = int (*)(const unsigned char* bytes, std::size_t size, int flags, cv::Mat* out, char* why,
                            std::size_t why_size);
/// Encodes `image` with cv::imencode(`extension`) into `out`; 0 on success.
using ImageEncodeFn = int (*)(const char* extension, const cv::Mat* image, std::vector<unsigned char>* out);

}  // namespace hedgefit::stereo
