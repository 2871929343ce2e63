"""The compiled passes pinclear.model._passes (pinclear/model/_cxx/passes.cpp, built by setup.py at install
time) against Pinocchio's Python bindings.

The bindings run the library functions (libpinocchio_default) one after the other; the
extension runs their joint steps fused into one forward sweep, each expression computed once
(passes.cpp). The same operations on the same numbers: every output must be bit-identical, over
joint kinds (revolute about an axis and an unaligned one, prismatic, free-flyer and spherical
with nq != nv, a mimic joint) and with armature. A wrong model/data address, a q/v length
mix-up, another crba convention, a flags bit read the wrong way, or a fused step that differs
from the library's by one operation shows as an exact mismatch."""
from __future__ import annotations

import ctypes
import os
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.model import native

FRAMES, MASS, POSITIONS, MASS_ONLY = native.FRAMES, native.MASS, native.POSITIONS, native.MASS_ONLY
PASSES_SIG = ctypes.CFUNCTYPE(None, *[ctypes.c_int64] * 5)


def _oMf(data):
    return np.array([f.homogeneous for f in data.oMf])


@pytest.fixture(scope="module")
def passes():
    if not native.available():
        pytest.skip(native.reason)
    return PASSES_SIG(native.passes_address())


def _model(name):
    # pinclear's mechanisms all have nq == nv; Pinocchio's sample humanoid has a free-flyer
    # (quaternion: nq = nv + 1), so a q read with nv entries or a v with nq would differ; with
    # armature, which crba adds to M's diagonal. four_ups_upu: unaligned revolute and prismatic
    # joints; mimic: the sample manipulator's joint 4 mimics joint 2 (crba's mimic step)
    if name == "humanoid":
        model = pin.buildSampleModelHumanoid()
        model.armature[:] = np.linspace(0.1, 1.0, model.nv)
        return model
    if name == "mimic":
        return pin.transformJointIntoMimic(pin.buildSampleModelManipulator(), 2, 4, 1.5, 0.3)
    return pinclear.load(name).model


@pytest.mark.parametrize("name", ["four_bar", "humanoid", "four_ups_upu", "nine_bar", "mimic"])
@pytest.mark.parametrize("flags", [FRAMES | MASS, FRAMES, MASS, 0, POSITIONS, POSITIONS | MASS, POSITIONS | FRAMES,
                                   MASS_ONLY])
def test_passes_equal_python_bindings(passes, name, flags):
    """The reference is pinclear.model.native.python_passes: flags' sequence of Pinocchio calls through
    the bindings, also the fallback run through a C callback when the extension is missing (so
    the fallback and the extension are equal)."""
    model = _model(name)
    ref, out = model.createData(), model.createData()
    maddr, daddr = native.addresses(model, out)
    mass = flags & (MASS | MASS_ONLY)
    rng = np.random.default_rng(7)
    sentinel_M = np.full((model.nv, model.nv), 0.25)
    for _ in range(10):
        q = np.ascontiguousarray(pin.integrate(model, pin.neutral(model), rng.standard_normal(model.nv)))
        v = np.ascontiguousarray(rng.standard_normal(model.nv))
        # a pass that is skipped must leave its outputs as they were. The C++ crba writes only
        # the upper-triangle entries of joints on one branch (the bindings' crba zeroes M
        # first), so with the mass pass M starts at zero, as in a fresh Data
        out.M[:] = 0.0 if mass else sentinel_M
        oMf_before = _oMf(out)
        native.python_passes(model, ref, q, v, flags)
        passes(maddr, daddr, q.ctypes.data, v.ctypes.data, flags)
        assert np.array_equal(out.nle, ref.nle)
        assert np.array_equal(out.J, ref.J)
        assert np.array_equal(out.dJ, ref.dJ)
        if not flags & (POSITIONS | MASS_ONLY):
            assert np.array_equal(np.array([m.vector for m in out.v]), np.array([m.vector for m in ref.v]))
        assert np.array_equal(np.array([m.homogeneous for m in out.oMi]),
                              np.array([m.homogeneous for m in ref.oMi]))
        if mass:
            # the bindings' crba also mirrors M into the lower triangle
            assert np.array_equal(np.triu(out.M), np.triu(ref.M))
        else:
            assert np.array_equal(out.M, sentinel_M)
        if flags & FRAMES:
            assert np.array_equal(_oMf(out), _oMf(ref))
        else:
            assert np.array_equal(_oMf(out), oMf_before)


def test_env_switch_turns_native_off():
    """PINCLEAR_NATIVE=0 falls back whether or not the extension was built, and says why."""
    env = dict(os.environ, PINCLEAR_NATIVE="0")
    res = subprocess.run([sys.executable, "-c",
                          "import pinclear.model.native as n; print(n.available()); print(n.reason)"],
                         env=env, capture_output=True, text=True, timeout=120, check=True)
    available, reason = res.stdout.strip().splitlines()
    assert available == "False"
    assert "PINCLEAR_NATIVE" in reason
