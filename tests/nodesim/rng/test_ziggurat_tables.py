"""The vendored ziggurat tables (nodesim.rng.ziggurat_tables) are numpy's: they satisfy the ziggurat's
defining relations and, used by nodesim.rng.pcg64, reproduce numpy's standard_normal through every strip."""

import ast
from pathlib import Path

import numpy as np

from nodesim.rng import pcg64
from nodesim.rng import ziggurat_tables as z

REPO = Path(__file__).resolve().parents[3]


def test_tables_satisfy_the_ziggurat_relations():
    """x_i = wi[i] 2^52 (strip right edges, x_255 = r); fi[i] = exp(-x_i^2 / 2) for i >= 1, fi[0] = 1;
    ki[i] = floor(x_{i-1} / x_i 2^52) (to one unit) for i >= 2 (Marsaglia & Tsang 2000, numpy's layout)."""
    assert z.ki_double.dtype == np.uint64 and z.ki_double.shape == (256,)
    x = z.wi_double * 2.0**52
    assert x[255] == z.ziggurat_nor_r
    assert abs(z.ziggurat_nor_inv_r * z.ziggurat_nor_r - 1.0) < 1e-15
    assert np.all(np.diff(x[1:]) > 0)
    assert z.fi_double[0] == 1.0
    assert np.max(np.abs(z.fi_double[1:] - np.exp(-0.5 * x[1:] ** 2))) < 1e-15
    ratio = np.floor(x[1:-1] / x[2:] * 2.0**52)
    assert np.max(np.abs(ratio - z.ki_double[2:].astype(float))) <= 1.0


def test_every_strip_draws_numpys_normals():
    """200,000 draws visit all 256 strips (index = low byte of the 64-bit output) and equal numpy's."""
    seqs = [np.random.SeedSequence(7, spawn_key=(i,)) for i in range(4)]
    states = pcg64.seeded(np.stack([s.generate_state(4, np.uint64) for s in seqs]))
    out = np.empty((4, 50_000))
    pcg64.fill_normals(states, out)
    ref = np.stack([np.random.Generator(np.random.PCG64(s)).standard_normal(50_000) for s in seqs])
    assert np.array_equal(out, ref)
    raw = np.random.Generator(np.random.PCG64(seqs[0])).bit_generator.random_raw(50_000)
    assert len(np.unique(raw & np.uint64(0xFF))) == 256


def test_no_private_module_of_a_dependency_is_imported():
    """No ``import a._b`` / ``from a._b import`` of a third-party package in the installed packages."""
    offenders = []
    for package in ("nodesim", "firmware_model", "channel"):
        for path in (REPO / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                for name in names:
                    top, *rest = name.split(".")
                    if top not in ("nodesim", "firmware_model", "channel") and any(p.startswith("_") for p in rest):
                        offenders.append(f"{path.relative_to(REPO)}: {name}")
    assert offenders == []
