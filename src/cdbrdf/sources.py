"""Table sources: "is this a CDBRDF or a CD-BTF, an object or a file?" decided in one place.

:func:`open_source` takes what a user gives as a table (a
:class:`~cdbrdf.CDBRDF`, a :class:`~cdbrdf.CDBTF`, a CDBRDF or CD-BTF file,
a glTF asset written by ``cdbrdf export``) and returns the table with its
material name, reading a file once: the CDBRDF variables are read in one
HDF5 open, which also says whether the file holds the CD-BTF variables;
only then are those read (a second open, of a CD-BTF file alone).

Examples
--------
>>> import cdbrdf.materials
>>> from cdbrdf.sources import open_source
>>> table, name = open_source(cdbrdf.materials.load("denim"))
>>> name
'denim'
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from .errors import OptionError

if TYPE_CHECKING:
    from .btf import CDBTF
    from .table import CDBRDF

__all__ = ["BTF_MARK", "Source", "open_source", "material_name"]

#: The global attribute that marks a CDBRDF file as a CD-BTF file (:mod:`cdbrdf.btf.file`).
BTF_MARK = "btf_repeat_mm"


class Source(NamedTuple):
    """A table and its material name, as :func:`open_source` gives them (unpacks as ``table, name``).

    Attributes
    ----------
    table
        The :class:`~cdbrdf.CDBRDF` or :class:`~cdbrdf.CDBTF`.
    name
        The material's name: the table's ``material`` attribute, else the file's stem, else ``"table"``.
    """

    table: CDBRDF | CDBTF
    name: str

    @property
    def is_btf(self) -> bool:
        """Whether the table is a CD-BTF."""
        return self.btf is not None

    @property
    def btf(self) -> CDBTF | None:
        """The :class:`~cdbrdf.CDBTF`, or None for a CDBRDF."""
        from .btf import CDBTF

        return self.table if isinstance(self.table, CDBTF) else None

    @property
    def flat(self) -> CDBRDF:
        """The CDBRDF: the table, or a CD-BTF's tile mean."""
        from .btf import CDBTF

        return self.table.mean() if isinstance(self.table, CDBTF) else self.table


def material_name(table: Any, path: str | PathLike[str] | None = None) -> str:
    """A table's material name: its ``material`` attribute, else the file's stem, else ``"table"``.

    Parameters
    ----------
    table
        A :class:`~cdbrdf.CDBRDF` or :class:`~cdbrdf.CDBTF`.
    path
        The file it was read from, if any.

    Returns
    -------
    str
        The name.
    """
    name = getattr(table, "attrs", {}).get("material")
    if name:
        return str(name)
    return Path(path).stem if path is not None else "table"


def open_source(source: Any, *, what: str = "table") -> Source:
    """The table of ``source`` and its material name, a file read once.

    Parameters
    ----------
    source
        A :class:`~cdbrdf.CDBRDF`, a :class:`~cdbrdf.CDBTF`, a :class:`Source`,
        or the path of a CDBRDF or CD-BTF file (``.h5``) or of a glTF asset
        (``.glb``/``.gltf``) holding a table.
    what
        How an error message names the argument.

    Returns
    -------
    Source
        ``(table, name)``: a CD-BTF file gives its :class:`~cdbrdf.CDBTF`.

    Raises
    ------
    OptionError
        For another kind of value.
    FileNotFoundError, FormatError, LimitError
        As :func:`cdbrdf.load` and :func:`cdbrdf.btf.load` raise them.
    """
    from .btf import CDBTF
    from .table import CDBRDF

    if isinstance(source, Source):
        return source
    if isinstance(source, (CDBRDF, CDBTF)):
        return Source(source, material_name(source))
    if not isinstance(source, (str, PathLike)):
        raise OptionError(f"{what}: expected a CDBRDF, a CDBTF or a file name, got {type(source).__name__:.40}")
    from .gltf_table import is_gltf
    from .table import load_parts

    if is_gltf(source):
        from .table import load

        table: CDBRDF | CDBTF = load(source)
    else:
        mean, file_attrs = load_parts(source)
        if file_attrs is None:  # read in a child process: the file's attributes were not seen
            from .btf import is_btf

            marked = is_btf(source)
        else:
            marked = BTF_MARK in file_attrs
        if marked:
            from .btf import load as load_btf

            table = load_btf(source, mean=mean)
        else:
            table = mean
    return Source(table, material_name(table, source))
