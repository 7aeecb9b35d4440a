"""Only the compiled kernels live here; everything else is in pyproject.toml.

The extensions are optional: where no C compiler is found the install still succeeds and
numpy does their work (runtime/whitted.py and runtime/color.py check for the modules)."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "runtime._whitted",
            ["runtime/kernel/whitted.c"],
            depends=[
                "runtime/kernel/blob.h",
                "runtime/kernel/bracket.h",
                "runtime/kernel/buffer.h",
                "runtime/kernel/noise.h",
                "runtime/kernel/poly.h",
                "runtime/kernel/slab.h",
                "runtime/kernel/superellipsoid.h",
                "runtime/kernel/sweep.h",
                "runtime/kernel/lathe.h",
                "runtime/kernel/bump_map.h",
            ],
            extra_compile_args=["-O3", "-fno-math-errno"],
            # linked to libm, not left to bind at load time: an unversioned `pow` bound to
            # glibc's oldest version, a wrapper around the fast one (a fifth slower)
            libraries=["m"],
            optional=True,
        ),
        Extension(
            "runtime._boxtree",
            ["runtime/kernel/boxtree.c"],
            depends=["runtime/kernel/buffer.h", "runtime/kernel/slab.h"],
            # no fused multiply-adds: the slab test must round as numpy's formula does
            extra_compile_args=["-O3", "-ffp-contract=off"],
            libraries=["m"],
            optional=True,
        ),
        Extension(
            "runtime._pixels",
            ["runtime/kernel/pixels.c"],
            extra_compile_args=["-O3"],
            optional=True,
        ),
    ]
)
