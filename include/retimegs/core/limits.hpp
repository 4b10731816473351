#pragma once
// One limit per quantity a user gives (in a file or an option), checked where a reader first sees
// it: a value beyond it is a typo, and would otherwise end far from its cause (an allocation
// failure naming nothing, a 1x1 image, NaNs at step 0). `field` names the key or option in the
// message ("scene.json: 'cameras[0].width'", "--tile-width").
#include <string>

namespace retimegs {

// Pixels per image side: a 16K frame. A render holds ~40 bytes per pixel.
constexpr int kMaxImageSide = 16384;
// Pixels per side of a rendered image: below this it shows nothing (--scale 1e-9: a 1x1 PNG).
constexpr int kMinOutputSide = 8;
// Frames of a clip or of a rendered sequence: an hour at 25 fps and more.
constexpr long kMaxFrames = 100000;
// Frames one render or export command writes (a slow motion of a long clip): a typo such as
// --slowmo 1000000000 or a retime keyframe at frame 9992992 would otherwise allocate and render
// for hours.
constexpr long kMaxOutputFrames = 1'000'000;
// Frame rates: a frame a minute to a high-speed camera's.
constexpr double kMinFps = 1.0 / 60, kMaxFps = 10000;
// Focal length over the image side: from a 179.9° to a 0.06° field of view.
constexpr double kMinFocalPerSide = 1e-3, kMaxFocalPerSide = 1e3;
// Coordinates of a camera centre, in scene units: 10 000 km in metres, far beyond any capture;
// more leaves too few digits of float precision for the scene itself.
constexpr double kMaxCoordinate = 1e7;
// Seams of a merged model (merge): 256 windows. The slice's settings carry them by value into the
// CUDA kernels, whose parameters are limited to a few KiB.
constexpr int kMaxSeams = 255;
// A merged model's seam fade (merge --seam-fade), in training intervals: 0 keeps γ; beyond one
// interval each side's weight at the neighbouring training frames, which it never saw, passes
// a quarter.
constexpr double kMaxSeamFade = 1.0;

// Each throws Error "<field> = <value> ..." naming the range when the value is outside it.
void check_image_side(double side, const std::string& field);  // a double: any number read
// An image to be made, width x height pixels (doubles: an absurd scale must not overflow):
// each side in [kMinOutputSide, kMaxImageSide]. `field` says what makes it ("--scale: 0.001
// makes camera 'cam00' (640x360)"); the size follows it in the message.
void check_output_size(double width, double height, const std::string& field);
void check_frame_count(long frames, const std::string& field);
void check_fps(double fps, const std::string& field);
void check_focal(double focal, int side, const std::string& field);  // side: the image's, pixels
void check_coordinate(double value, const std::string& field);
void check_seam_fade(double intervals, const std::string& field);

}  // namespace retimegs
