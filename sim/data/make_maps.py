"""Regenerate the shipped example maps from published fits: the LiU-D-El compressor (Sivertsson &
Eriksson, with its surge line) and the Wahlström & Eriksson turbine.

Usage::

    python sim/data/make_maps.py            # writes we_compressor.toml and we_turbine.toml here

The maps are computed by :func:`transgen.sim.engine.map_generator.generate_compressor_map` and
:func:`transgen.sim.engine.map_generator.generate_turbine_map`; each file carries its
provenance header.
"""
from pathlib import Path

from transgen.sim.engine import generate_compressor_map, generate_turbine_map, save_map


def main(folder: Path = Path(__file__).resolve().parent) -> None:
    for name, m in (("we_compressor.toml", generate_compressor_map()),
                    ("we_turbine.toml", generate_turbine_map())):
        print("wrote", save_map(m, folder / name))


if __name__ == "__main__":
    main()
