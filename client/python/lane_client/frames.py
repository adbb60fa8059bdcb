"""Turns what a Python user holds into the image of a FrameRequest.

  * bytes, bytearray, memoryview: a JPEG or PNG file's bytes -> `encoded`;
  * str or os.PathLike: the path of a JPEG or PNG file, read -> `encoded`;
  * a numpy array (as OpenCV returns it) -> `raw` (RawImage), uncompressed:
      H x W x 3 uint8: PIXEL_FORMAT_BGR8, OpenCV's order (rgb=True: RGB8);
      H x W or H x W x 1 uint8: PIXEL_FORMAT_GRAY8.
    A non-contiguous array (a crop, a channel view) is copied into packed
    rows first. Raw frames cost no JPEG encode on the client and no decode
    on the server, at about 10x the bytes of a JPEG.

numpy is imported only when an array is given, so the package works on
bytes without it. OpenCV (python3-opencv) is never needed: an array from
cv2.imread or cv2.VideoCapture.read is simply a numpy array.
"""

import os


def _is_array(image):
    return hasattr(image, "__array_interface__") and hasattr(image, "shape") \
        and hasattr(image, "dtype")


def fill_image(request, image, pb2, rgb=False):
    """Sets request.encoded or request.raw from `image` (see the module's doc)."""
    if isinstance(image, (bytes, bytearray, memoryview)):
        request.encoded = bytes(image)
        return request
    if isinstance(image, (str, os.PathLike)):
        with open(image, "rb") as f:
            request.encoded = f.read()
        return request
    if _is_array(image):
        import numpy as np

        array = np.asarray(image)
        if array.dtype != np.uint8:
            raise TypeError(f"a frame array must be uint8, not {array.dtype} "
                            "(scale and convert it: array.astype(numpy.uint8))")
        if array.ndim == 3 and array.shape[2] == 1:
            array = array[:, :, 0]
        if array.ndim == 2:
            pixel_format = pb2.PIXEL_FORMAT_GRAY8
        elif array.ndim == 3 and array.shape[2] == 3:
            pixel_format = pb2.PIXEL_FORMAT_RGB8 if rgb else pb2.PIXEL_FORMAT_BGR8
        elif array.ndim == 3 and array.shape[2] == 4:
            raise TypeError("a 4-channel frame (BGRA) is not accepted: drop alpha first, "
                            "e.g. cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR) or frame[:, :, :3]")
        else:
            raise TypeError(f"a frame array must be H x W x 3 (BGR) or H x W (grey), "
                            f"not of shape {array.shape}")
        height, width = array.shape[0], array.shape[1]
        if height == 0 or width == 0:
            raise ValueError(f"empty frame array of shape {array.shape}")
        raw = request.raw
        raw.width = width
        raw.height = height
        raw.stride = 0  # packed rows
        raw.pixel_format = pixel_format
        raw.data = np.ascontiguousarray(array).tobytes()
        return request
    raise TypeError(
        "a frame must be JPEG/PNG bytes, a path to such a file, or a numpy uint8 array "
        f"(H x W x 3 BGR or H x W grey), not {type(image).__name__}")
