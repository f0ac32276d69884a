"""The C reference firmware builds on the host with cffi (firmware_model.c_reference) and its primitives agree
with the model's (firmware_model.fixed_kernel) on a few hand-checked values; the hypothesis comparisons of
every C function live beside the tests of the Python function they mirror."""

from firmware_model import c_reference


def test_builds_and_loads():
    ffi, lib = c_reference.load()
    assert lib.nf_abi_version() == 1
    assert c_reference.load() == (ffi, lib)  # cached


def test_rounded_division_is_half_even():
    _, lib = c_reference.load()
    assert [lib.fx_div_round(n, 2) for n in (-7, -5, -3, 3, 5, 7)] == [-4, -2, -2, 2, 2, 4]
    assert lib.fx_div_round(10, 3) == 3 and lib.fx_div_round(-10, 3) == -3
