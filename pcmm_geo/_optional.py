"""Optional dependencies: one place that imports them on first use and names the extra.

The core install (``pip install pcmm_geo``) needs numpy and scipy only.  Heavier packages
come with extras; a function that needs one calls :func:`require` inside its body, so
``import pcmm_geo`` stays fast and a missing package gives a
:class:`~pcmm_geo.errors.MissingDependencyError` that says what to install.

=============  ==================  ======================================================
extra          distributions       used by
=============  ==================  ======================================================
``cad``        open3d, trimesh     CAD comparison, mesh and point-cloud file formats
``acquire``    pyserial            serial drivers of the acquisition package
``plots``      matplotlib          every figure (``--plot``, ``--report``)
``progress``   rich                progress bars of the ``pcmm`` command (optional: no bar
                                   without it)
``dask``       dask[array],        fits of clouds that do not fit in memory, lazy point
               distributed         files (``read_points_lazy``)
``e57``        pye57, defusedxml,  E57 scanner files (``read_points``; the XML section is
               google-crc32c       checked before pye57 reads the file)
``qif``        defusedxml, lxml    QIF 3.0 files (defusedxml reads, lxml validates)
=============  ==================  ======================================================

Examples
--------
>>> from pcmm_geo import require
>>> require("numpy").__name__
'numpy'
>>> OPTIONAL_MODULES["trimesh"]
('trimesh', 'cad')
"""

from __future__ import annotations

import importlib
import sys
from types import ModuleType

from pcmm_geo.errors import MissingDependencyError

__all__ = ["OPTIONAL_MODULES", "available", "require"]

#: top-level import name -> (distribution name, extra providing it)
OPTIONAL_MODULES: dict[str, tuple[str, str]] = {
    "open3d": ("open3d", "cad"),
    "trimesh": ("trimesh", "cad"),
    "serial": ("pyserial", "acquire"),
    "matplotlib": ("matplotlib", "plots"),
    "rich": ("rich", "progress"),
    "dask": ("dask[array]", "dask"),
    "distributed": ("distributed", "dask"),
    "pye57": ("pye57", "e57"),
    "google_crc32c": ("google-crc32c", "e57"),
    "defusedxml": ("defusedxml", "qif"),
    "lxml": ("lxml", "qif"),
    "shtab": ("shtab", "completion"),
}


def require(module: str, *, purpose: str | None = None, extra: str | None = None) -> ModuleType:
    """Import ``module`` (e.g. ``"trimesh"`` or ``"matplotlib.figure"``), naming the extra when absent.

    Parameters
    ----------
    module : str
        Dotted module name; its top-level package decides the extra.
    purpose : str, optional
        What needs it, for the message (default: the calling function's qualified name).
    extra : str, optional
        The extra to name when a package serves several (defusedxml is in ``qif`` and ``e57``);
        default: the one in :data:`OPTIONAL_MODULES`.

    Returns
    -------
    module

    Raises
    ------
    MissingDependencyError
        The package is not installed (also an :class:`ImportError`); ``.extra`` and
        ``.package`` say what to install, e.g. ``pip install 'pcmm_geo[cad]'``.

    Examples
    --------
    >>> import sys
    >>> saved = sys.modules.get("trimesh")
    >>> sys.modules["trimesh"] = None  # simulate an install without the [cad] extra
    >>> try:
    ...     require("trimesh", purpose="CAD comparison")
    ... except ImportError as exc:
    ...     print(exc.extra, exc.package)
    cad trimesh
    >>> if saved is None:
    ...     del sys.modules["trimesh"]
    ... else:
    ...     sys.modules["trimesh"] = saved
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        _reraise_interrupt(exc)
        top = module.split(".")[0]
        if top not in OPTIONAL_MODULES:
            raise
        package, default_extra = OPTIONAL_MODULES[top]
        extra = extra or default_extra
        if purpose is None:
            caller = sys._getframe(1)
            purpose = f"{caller.f_globals.get('__name__', '?')}.{caller.f_code.co_qualname}"
        error = MissingDependencyError(package, extra, purpose)
        error.name = top
        raise error from exc


def available(module: str) -> bool:
    """True when ``module`` can be imported (it is imported to find out).

    Examples
    --------
    >>> available("numpy")
    True
    """
    try:
        importlib.import_module(module)
    except ImportError as exc:
        _reraise_interrupt(exc)
        return False
    return True


def _reraise_interrupt(error: ImportError) -> None:
    """An import that failed because Ctrl-C (or SIGTERM, SIGHUP) arrived while it loaded stays an interrupt.

    Extension modules (open3d's pybind11 core) turn an exception raised during their
    initialisation into ``ImportError("initialization failed")``: without this, Ctrl-C while
    open3d loads read as "open3d is not installed".
    """
    from pcmm_geo._signals import interruption

    interrupt = interruption(error)
    if interrupt is not None:
        raise interrupt from None
