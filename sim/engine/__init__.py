"""The turbocharged engine of thesis chapter 4 and the torque converter: ``transgen.sim.engine``.

The package re-exports the public names of its modules, so ``transgen.sim.engine.TurbochargedDiesel``,
``transgen.sim.engine.rate`` or ``transgen.sim.engine.load_map`` work without naming the module.
Data flow one way, from the top of the list to the bottom:

* :mod:`~transgen.sim.engine.gas` - ideal gases, corrected quantities, isentropic outlet
  temperatures, torque from power (units: rad/s, K, Pa);
* :mod:`~transgen.sim.engine.map_file` - compressor and turbine maps in a manufacturer-like TOML
  format: reader, writer, validation (:class:`MapError`);
* :mod:`~transgen.sim.engine.preprocessor` - the map pre-processor (thesis 4.4): causal tables
  over corrected speed and chi (compressor) or expansion ratio (turbine);
* :mod:`~transgen.sim.engine.map_generator` - the shipped maps regenerated from the published
  Wahlström & Eriksson fits;
* :mod:`~transgen.sim.engine.turbomachine`, :mod:`~transgen.sim.engine.compressor`,
  :mod:`~transgen.sim.engine.turbine` - quasi-steady compressor and turbine from their tables
  (thesis 4.3);
* :mod:`~transgen.sim.engine.turbocharger` - the two turbocharger algorithms, basic and
  iterative with kinetic energy (thesis 4.4, 4.5);
* :mod:`~transgen.sim.engine.diesel` - the mean-value turbodiesel and its steady state;
* :mod:`~transgen.sim.engine.rating` - its full-load curve and rating (:func:`rate`);
* :mod:`~transgen.sim.engine.torque_converter` - the hydrodynamic torque converter;
* :mod:`~transgen.sim.engine.turbo_report`, :mod:`~transgen.sim.engine.plots`,
  :mod:`~transgen.sim.engine.map_summary` - the turbocharger report of a run, the thesis'
  figures, and the summary of a map (``transgen maps``); the last two are not re-exported.

How the engine and the converter become components of the shift simulator is
:mod:`transgen.sim.model.powertrain`; the causality check of such an assembly is
:mod:`transgen.sim.model.assembly`.  The shipped maps and converter table are in ``sim/data/``
(:data:`DATA_DIR`).
"""
from __future__ import annotations

from .compressor import *  # noqa: F401,F403
from .compressor import __all__ as _compressor
from .diesel import *  # noqa: F401,F403
from .diesel import __all__ as _diesel
from .gas import *  # noqa: F401,F403
from .gas import __all__ as _gas
from .map_file import *  # noqa: F401,F403
from .map_file import __all__ as _map_file
from .map_generator import *  # noqa: F401,F403
from .map_generator import __all__ as _map_generator
from .preprocessor import *  # noqa: F401,F403
from .preprocessor import __all__ as _preprocessor
from .rating import *  # noqa: F401,F403
from .rating import __all__ as _rating
from .torque_converter import *  # noqa: F401,F403
from .torque_converter import __all__ as _torque_converter
from .turbine import *  # noqa: F401,F403
from .turbine import __all__ as _turbine
from .turbo_report import *  # noqa: F401,F403
from .turbo_report import __all__ as _turbo_report
from .turbocharger import *  # noqa: F401,F403
from .turbocharger import __all__ as _turbocharger
from .turbomachine import *  # noqa: F401,F403
from .turbomachine import __all__ as _turbomachine

__all__ = [*_gas, *_map_file, *_preprocessor, *_map_generator, *_turbomachine, *_compressor, *_turbine,
           *_turbocharger, *_diesel, *_rating, *_torque_converter, *_turbo_report]
