// SPDX-License-Identifier: Apache-2.0
// rockvdb — single-channel images (heightfields, reliefs) and PNG output.
#pragma once

#include <cstdint>
#include <string>
#include <vector>
#include <utility>

namespace rockvdb {

/// @brief A single-channel float image, row-major: value(i, j) = pixels[j·width + i], row 0 is
/// the first row stored in the file.
struct GrayImage
{
    int width = 0, height = 0;
    std::vector<float> pixels;
    float at(int i, int j) const { return pixels[size_t(j) * size_t(width) + size_t(i)]; }
};

/// @brief Read a single-channel float EXR (values as stored) or a 16-bit greyscale PNG
/// (0..65535 mapped to 0..1), chosen by content.
/// @throw IoError for a missing or unreadable file, or one whose header claims more pixels
///        than its bytes can hold; ValueError for a wrong channel count or bit depth (the
///        message says what was found), or an image over @a maxMemoryBytes (0: 75% of RAM).
GrayImage readGrayImage(const std::string& path, const char* op = "image", double maxMemoryBytes = 0);

/// @brief Encode an 8-bit RGB image (row-major, 3 bytes per pixel) as PNG bytes.
std::string encodePngRgb8(int width, int height, const std::vector<uint8_t>& rgb);

/// @brief Encode a grey (@a channels 1) or RGB (3) image of 8 or 16 @a bits per channel as PNG
/// bytes: @a values row-major, interleaved, rows from the top, each in [0, 2^bits - 1].
/// @throw ValueError for another channel count or bit depth, or too few values.
std::string encodePng(int width, int height, int channels, int bits, const std::vector<uint16_t>& values);

/// @brief Write a single-channel image atomically: ".exr" as 32-bit float EXR (channel "Y"),
/// ".png" as 16-bit greyscale PNG (values clamped to [0, 1] and scaled to 0..65535).
void writeGrayImage(const std::string& path, const GrayImage& image);

/// @brief Channels R, G, B of an EXR, interleaved, rows from the top (what writeRgbExr
/// writes). @throw ValueError for a file that is not an EXR or lacks a channel, IoError for
/// one that cannot be read.
std::vector<float> readRgbExr(const std::string& path, int& width, int& height, const char* op = "image");

/// @brief Write an RGB float EXR (channels R, G, B; @a rgb interleaved, rows from the top)
/// atomically, with @a attributes as string attributes of its header (name, value).
/// @throw ValueError unless @a path ends in ".exr".
void writeRgbExr(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 const std::vector<std::pair<std::string, std::string>>& attributes = {});

} // namespace rockvdb
