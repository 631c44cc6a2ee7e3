"""The turbocharged engine of thesis chapter 4 and the torque converter: ``transgen.sim.engine``.

The package re-exports the public names of its modules (``transgen.sim.engine.TurbochargedDiesel``,
``transgen.sim.engine.rate``, ``transgen.sim.engine.load_map``, ...).
"""
from __future__ import annotations

from .compressor import *  # noqa: F401,F403
from .diesel import *  # noqa: F401,F403
from .map_file import *  # noqa: F401,F403
from .torque_converter import *  # noqa: F401,F403
from .turbine import *  # noqa: F401,F403
from .turbocharger import *  # noqa: F401,F403
