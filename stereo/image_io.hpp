#pragma once
/// Reading and writing the images a stereo rig records. PNG and JPEG, what cameras write, are
/// decoded and encoded through libpng and libjpeg(-turbo) directly, with the same settings as
/// OpenCV's imread/imencode (so the pixels are the same); other formats (TIFF, BMP, PNM, PFM) go
/// through OpenCV's imgcodecs in a module of their own (libhedgefit_imgcodecs.so), loaded only
/// when such a file is met. imgcodecs links GDAL and some 140 other libraries, which cost every
/// hedgefit command ~75 ms of start-up. Unlike cv::imread, a JPEG's EXIF orientation is not
/// applied: a rig's images are used as its sensors recorded them, boards and captures alike.

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_ flags only: no imgcodecs function is linked

#include <string>
#include <vector>

namespace hedgefit::stereo {

/// What the first bytes of a file say it is: "png", "jpeg", "tiff", "bmp", "pnm", "pfm", or "".
std::string SniffImageFormat(const unsigned char* head, std::size_t size);

/// Decodes an image file's bytes. `flags` as cv::imread's: cv::IMREAD_COLOR (8-bit BGR),
/// cv::IMREAD_GRAYSCALE (8-bit grey) or cv::IMREAD_UNCHANGED (the file's depth and channels;
/// PNG: 8- or 16-bit, 1 to 4 channels). Throws hedgefit::Error starting with `name` when the
/// bytes cannot be decoded (damaged, cut short, or a format neither decoder reads).
cv::Mat DecodeImage(const std::vector<unsigned char>& bytes, int flags, const std::string& name);

/// A file's bytes, read in one call; throws hedgefit::Error naming `path` when it cannot be read.
std::vector<unsigned char> ReadFileBytes(const std::string& path);

/// Reads and decodes a file (DecodeImage); throws hedgefit::Error naming `path`.
cv::Mat ReadImageFile(const std::string& path, int flags = cv::IMREAD_COLOR);

/// Encodes `image` (8-bit, 1, 3 or 4 channels; 16-bit for PNG) in the format its extension
/// names: ".png" (zlib level 1, as OpenCV), ".jpg"/".jpeg" (`jpeg_quality`), others through the
/// imgcodecs module. Returns false when the format cannot hold the image or is unknown.
bool EncodeImage(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>* bytes,
                 int jpeg_quality = 95);

/// Writes `image` to `path` in the format its extension names (.png, .jpg, ...), atomically:
/// encoded in memory, written to a hidden temporary file beside it and renamed, so a failed
/// or killed run never leaves a half-written image under the final name. Throws
/// hedgefit::Error naming the file.
void WriteImageAtomic(const std::string& path, const cv::Mat& image);

}  // namespace hedgefit::stereo
