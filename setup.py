"""Package list and the optional C++ extension (everything else is in pyproject.toml).

The repository's urdf/ folder becomes the data package ``pinclear.urdf``, which a static find
cannot express. ``pinclear.model._passes`` (pinclear/model/_cxx/passes.cpp) is compiled against the headers
and libraries of the ``pin`` wheel in the build environment ([build-system] requires the same
``pin`` spec as the runtime, plus cmeel-eigen for the Eigen headers no runtime wheel ships). The
extension is optional: without a compiler, headers or libraries the install goes on without it
and pinclear.model.native falls back to Pinocchio's Python bindings.
"""
import os
import sys
from pathlib import Path

from setuptools import Extension, find_packages, setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import BaseError, CCompilerError

CMEEL_PREFIX = "cmeel.prefix"
PYTHON_LIB = f"boost_python{sys.version_info.major}{sys.version_info.minor}"


def _warn(msg: str) -> None:
    # one line on stderr: pip shows it with -v (it hides a successful build's output otherwise);
    # at run time pinclear.native.reason says the extension is missing
    print(f"WARNING: pinclear: {msg}; installing without the compiled passes "
          "(pinclear.model.native falls back to Pinocchio's Python bindings)", file=sys.stderr)


def _find_in_cmeel_prefixes(relative: str) -> Path | None:
    """The first ``<sys.path entry>/cmeel.prefix/<relative>`` that exists.

    cmeel wheels (pin, libpinocchio, cmeel-boost, cmeel-eigen) all install into
    site-packages/cmeel.prefix; in pip's isolated build environment that site-packages is one of
    the sys.path entries, which is also how cmeel's own ``cmeel lib`` finds it."""
    for entry in sys.path:
        candidate = Path(entry or ".") / CMEEL_PREFIX / relative
        if candidate.exists():
            return candidate
    return None


def _passes_extension() -> list[Extension]:
    if os.environ.get("PINCLEAR_NATIVE", "1") == "0":
        _warn("PINCLEAR_NATIVE=0 at build time")
        return []
    pinocchio_h = _find_in_cmeel_prefixes("include/pinocchio/multibody.hpp")
    eigen_core = _find_in_cmeel_prefixes("include/eigen3/Eigen/Core")
    if pinocchio_h is None:
        _warn("no cmeel.prefix/include/pinocchio on sys.path (the pin wheel is missing)")
        return []
    if eigen_core is None:
        _warn("no cmeel.prefix/include/eigen3 on sys.path (pip install cmeel-eigen)")
        return []
    prefix = pinocchio_h.parents[2]
    lib = prefix / "lib"
    for name in ("pinocchio_default", PYTHON_LIB):
        if not (lib / f"lib{name}.so").exists():
            _warn(f"lib{name}.so not found in {lib}")
            return []
    return [Extension(
        "pinclear.model._passes",
        sources=["pinclear/model/_cxx/passes.cpp"],
        # setuptools skips an extension whose build/ (or, editable, in-place) output is newer
        # than its sources and depends; pinocchio's version header makes a reinstall from the
        # same tree against another pin (whose headers are installed later) compile again
        depends=[str(p) for p in [prefix / "include" / "pinocchio" / "config.hpp"] if p.exists()],
        include_dirs=[str(prefix / "include"), str(eigen_core.parents[1])],
        library_dirs=[str(lib)],
        libraries=["pinocchio_default", PYTHON_LIB],
        define_macros=[
            # links against the explicit instantiations in libpinocchio_default instead of
            # compiling the algorithms again
            ("PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION", None),
            # what pinocchio's exported CMake target (cmeel.prefix/lib/cmake/pinocchio/
            # pinocchioTargets.cmake) asks of its users: the joint variant has more
            # alternatives than boost.mpl's default limits allow
            ("BOOST_MPL_LIMIT_LIST_SIZE", "30"), ("BOOST_MPL_LIMIT_VECTOR_SIZE", "30"),
            ("BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", None), ("BOOST_FUSION_INVOKE_MAX_ARITY", "12"),
            ("NDEBUG", None)],
        extra_compile_args=["-std=c++17", "-O2", "-g0", "-fvisibility=hidden",
                            "-Wno-deprecated-declarations"],
        # The libraries used at run time are the *installed* pin wheel's, never the (deleted)
        # build environment's: pinclear.native imports pinocchio first, which loads
        # libpinocchio_default/libboost_python by SONAME, and this RUNPATH to
        # site-packages/cmeel.prefix/lib (a non-editable install puts the module in
        # site-packages/pinclear/model/) is the fallback when the module is imported on its own.
        extra_link_args=["-Wl,-rpath,$ORIGIN/../../" + CMEEL_PREFIX + "/lib", "-s"],
        language="c++",
        # a failed compile or link is a warning, not a failed install
        optional=True,
    )]


class _OptionalBuildExt(build_ext):
    """setuptools already skips a failed optional extension, but its warning is the whole
    compiler command line; this one says what happened and what follows in one short line."""

    def build_extension(self, ext):
        try:
            super().build_extension(ext)
        except (CCompilerError, BaseError) as exc:
            if not ext.optional:
                raise
            # an output left in build/ by an earlier install would otherwise go into the wheel
            stale = Path(self.get_ext_fullpath(ext.name))
            if stale.exists():
                stale.unlink()
            _warn(f"building the extension {ext.name} failed ({exc})")


setup(packages=find_packages(include=["pinclear", "pinclear.*"]) + ["pinclear.urdf"],
      package_dir={"pinclear.urdf": "urdf"},
      # passes.cpp is the extension's source (it goes into the sdist), not package data
      exclude_package_data={"pinclear.model": ["_cxx/*"]},
      ext_modules=_passes_extension(),
      cmdclass={"build_ext": _OptionalBuildExt})
