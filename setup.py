"""Only the compiled kernel lives here; everything else is in pyproject.toml.

The extension is optional: where no C compiler is found the install still succeeds and
the numpy integrator renders every scene (runtime/whitted.py checks for the module)."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "runtime._whitted",
            ["runtime/kernel/whitted.c"],
            extra_compile_args=["-O3", "-fno-math-errno"],
            optional=True,
        )
    ]
)
