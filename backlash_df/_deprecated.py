"""The old module path ``backlash_df.simulate``, kept for one release (to be removed in 0.3).

Until 0.2 ``backlash_df.simulate`` was a module and, once the package was
imported, the function :func:`backlash_df.simulate`.  The module is now
:mod:`backlash_df.simulation` and the name means the function.  A notebook that
still imports from the module path (``from backlash_df.simulate import
simulated_limit_cycle``) gets its names from :mod:`backlash_df.simulation` with a
``DeprecationWarning``; the import system then binds the stand-in module to
``backlash_df.simulate``, so the stand-in is callable as the function was.
"""

import importlib.abc
import importlib.util
import sys
import types
import warnings

from . import simulation

__all__ = ["install_simulate_module_alias"]

_OLD = "backlash_df.simulate"
_MESSAGE = ("the module backlash_df.simulate is now backlash_df.simulation (backlash_df.simulate is the "
            "function simulate_rig); import from backlash_df.simulation")


class _SimulateModule(types.ModuleType):
    """Stands in for the old module: its names from :mod:`backlash_df.simulation`; calling it simulates."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        warnings.warn(_MESSAGE, DeprecationWarning, stacklevel=2)
        return getattr(simulation, name)

    def __call__(self, *args, **kwargs):
        return simulation.simulate_rig(*args, **kwargs)


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``backlash_df.simulate`` when no file does (it is last on ``sys.meta_path``)."""

    def find_spec(self, fullname, path=None, target=None):
        return importlib.util.spec_from_loader(fullname, self) if fullname == _OLD else None

    def create_module(self, spec):
        return _SimulateModule(spec.name, __doc__)

    def exec_module(self, module):
        warnings.warn(_MESSAGE, DeprecationWarning, stacklevel=2)


def install_simulate_module_alias():
    """Put the finder of the old module path last on ``sys.meta_path`` (once)."""
    if not any(isinstance(finder, _Finder) for finder in sys.meta_path):
        sys.meta_path.append(_Finder())
