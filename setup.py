"""The optional compiled part of the package: the deframer's steady state in C
(dissectors/_deframe.c). Everything else is in pyproject.toml.

``optional=True``: an install without a C compiler (or Python headers) still
succeeds, and the deframer then runs its pure-Python loop, which gives the same
events (docs/architecture.md, "Compiled deframing").
"""

from setuptools import Extension, setup

# -ffp-contract=off: event times are computed as Python computes them, a multiply
# then an add, never fused (a fused multiply-add rounds once, and gives other floats)
setup(ext_modules=[Extension("dissectors._deframe", ["dissectors/_deframe.c"], optional=True,
                             extra_compile_args=["-ffp-contract=off"])])
