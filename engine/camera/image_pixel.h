// The pixel of an image that a projected point falls in.
#ifndef POINTFORWARD_ENGINE_CAMERA_IMAGE_PIXEL_H_
#define POINTFORWARD_ENGINE_CAMERA_IMAGE_PIXEL_H_

namespace pf {

// Returns true, with the pixel (*x, *y) = (floor(u), floor(v)), when the
// continuous pixel coordinates (u, v) (CameraModel::Project's) lie inside a
// `width` x `height` image; false outside it and for NaN. The range test
// comes first: Project() leaves a point near the camera plane at 1e10 px or
// more, and converting a double outside int's range to int is undefined.
inline bool PixelInImage(double u, double v, int width, int height, int* x, int* y) {
  if (!(u >= 0 && v >= 0 && u < width && v < height)) return false;
  *x = static_cast<int>(u);
  *y = static_cast<int>(v);
  return true;
}

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_CAMERA_IMAGE_PIXEL_H_
