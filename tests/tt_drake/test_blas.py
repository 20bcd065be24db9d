"""The OpenBLAS kernel pin: set on x86-64 machines only, and never over the environment's own."""

import os

import pytest

from tt_drake import blas


@pytest.mark.parametrize("machine, expected", [("x86_64", blas.BLAS_CORE_TYPE),
                                               ("AMD64", blas.BLAS_CORE_TYPE),
                                               ("aarch64", None), ("arm64", None)])
def test_the_kernels_are_pinned_on_x86_64_only(monkeypatch, machine, expected):
    monkeypatch.setattr(blas.platform, "machine", lambda: machine)
    monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    blas.pin_blas_kernels()
    assert os.environ.get("OPENBLAS_CORETYPE") == expected


def test_a_kernel_family_the_environment_names_is_kept(monkeypatch):
    monkeypatch.setattr(blas.platform, "machine", lambda: "x86_64")
    monkeypatch.setenv("OPENBLAS_CORETYPE", "SkylakeX")
    blas.pin_blas_kernels()
    assert os.environ["OPENBLAS_CORETYPE"] == "SkylakeX"
