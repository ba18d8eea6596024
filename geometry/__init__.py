"""Pure projective geometry shared by the pipeline and the calibration library.

Nothing here does I/O, opens windows or touches GL; every function works on
numpy arrays and documents their shapes and frames.

Conventions (docs/formats.md, from DESIGN.md section 2), stated once here and repeated where used:

* Homogeneous vectors carry the scale last: a point is ``(x, y, w)``, a line
  ``(a, b, c)`` with ``a x + b y + c = 0``.
* A conic is a symmetric 3x3 matrix ``C`` with ``x^T C x = 0``, stored with
  unit Frobenius norm and the sign that makes its upper-left 2x2 block have a
  non-negative trace (for an ellipse: ``x^T C x < 0`` inside). The dual conic
  is ``C* = adj(C)``.
* Cameras follow OpenCV: ``x ~ K (R X + t)``, camera looks down +z, image x
  right, y down, pixel centres at integer coordinates.
* The pitch frame: metres, origin at the centre spot, X along the touchlines,
  Y along the halfway line away from the main camera, Z up; pitch plane Z = 0.
"""

from geometry import camera, conics, homography, lines, pitch

__all__ = ["camera", "conics", "homography", "lines", "pitch"]
