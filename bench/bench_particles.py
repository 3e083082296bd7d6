"""Particle erosion (003) benchmarks: particles and impacts per second, rain preset.

A fractal heightfield (spectral synthesis, 20 m cells, ~600 m of relief), 100 000 rain
particles in one iteration, each traced until it settles, leaves the domain or expires, then
the impacts applied; 1 and 2 numba threads. Scaling in particle count: 25 000, 100 000 and
400 000 particles at 512² on 2 threads. The impact count of a case is measured once while
setting it up (it does not depend on the threads).
"""

from __future__ import annotations

import numba
import numpy as np

from harness import benchmark
from unerode_cli.grid import Grid
from unerode_cli.particles import Emission, HeightfieldTerrain, preset_params, run

SIZES = (512, 2048)
THREADS = (1, 2)
DX = 20.0
PARTICLES = 100_000
SCALING = (25_000, 400_000)


def _fractal(n: int) -> np.ndarray:
    rng = np.random.default_rng(n)
    k = np.hypot(*np.meshgrid(np.fft.fftfreq(n), np.fft.fftfreq(n)))
    k[0, 0] = np.inf
    spectrum = (rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))) * k**-2.0
    z = np.fft.ifft2(spectrum).real
    return 600.0 * (z - z.min()) / (z.max() - z.min())


def _case(n: int, threads: int, unit: str, particles: int = PARTICLES):
    terrain = HeightfieldTerrain(_fractal(n), Grid.full((n, n), DX))
    params = preset_params("rain", DX)
    emission = Emission.rain(particles)

    def work():
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        return run(terrain, params, emission, seed=1)

    amount = particles if unit == "particles" else work().stats.impacts
    return work, amount, unit


for _n in SIZES:
    for _t in THREADS:
        for _unit in ("particles", "impacts"):
            benchmark(f"particles/rain {_unit} {_n}² {_t} thread{'s' if _t > 1 else ''}")(
                lambda n=_n, t=_t, u=_unit: _case(n, t, u))
for _count in SCALING:
    benchmark(f"particles/rain particles 512² 2 threads, {_count // 1000}k particles")(
        lambda c=_count: _case(512, 2, "particles", c))
