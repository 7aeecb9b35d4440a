"""strala's renderer: the evaluated scene (lang.ir) to an image, with the compiled kernel,
Embree for triangles, numpy as the reference path and the radiosity solver; the command line
and the Python API."""
