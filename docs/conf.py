"""Sphinx configuration of the cdbrdf reference site (built by ``bash scripts/docs.sh``).

The site is the guides of ``docs/*.md`` (MyST), the API reference generated from
the docstrings (autosummary + numpydoc) and a gallery of examples in
``examples/`` that sphinx-gallery executes on every build. The build reads
nothing from the network: intersphinx is off unless ``CDBRDF_DOCS_INTERSPHINX=1``.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "src"))

import numpydoc.validate as _numpydoc_validate  # noqa: E402
import sphinx.ext.autosummary as _autosummary  # noqa: E402

import cdbrdf  # noqa: E402

project = "cdbrdf"
author = "The cdbrdf developers"
copyright = "The cdbrdf developers"  # noqa: A001
release = cdbrdf.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
if os.environ.get("CDBRDF_DOCS_INTERSPHINX") == "1":  # fetches other projects' inventories
    extensions.append("sphinx.ext.intersphinx")
    intersphinx_mapping = {
        "python": ("https://docs.python.org/3", None),
        "numpy": ("https://numpy.org/doc/stable", None),
        "xarray": ("https://docs.xarray.dev/en/stable", None),
        "matplotlib": ("https://matplotlib.org/stable", None),
    }

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = ["_build", "gallery/*.ipynb", "gallery/*.py.md5", "gallery/*.zip", "gallery/*.json"]

# -- API reference ------------------------------------------------------------------
autosummary_generate = True
autosummary_ignore_module_all = False  # a module's page lists its __all__
autosummary_imported_members = True  # packages re-export their modules' objects
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "signature"  # the signatures show the type hints
autodoc_typehints_format = "short"
autodoc_mock_imports: list[str] = []
numpydoc_show_class_members = False  # the class templates list the members
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = True
add_module_names = False
# numpydoc's checks of every documented docstring (warnings, so errors under -W), but
# for sections the project does not require everywhere: an extended summary, See
# Also, Examples, types in the docstring (the signature shows the type hints) and
# the wording rules on summaries' first words. A class documented by an Attributes
# section (the dataclasses) lists its fields there rather than under Parameters.
numpydoc_validation_checks = {"all", "ES01", "SA01", "EX01", "PR04", "SS05", "SS02", "RT04", "PR08"}
numpydoc_validation_overrides = {"PR01": [r"\n\s*Attributes\n\s*-{3,}\n"]}
# Methods of the cloth model whose Parameters and Returns sections are still to be
# written (synth/cloth.py is close to the module size limit).
_UNDOCUMENTED = (
    r"^cdbrdf\.synth\.(ClothModel\.(attrs|heightfield|stretch|tilts_rad)"
    r"|ClothParams\.(parse_value|replace|to_dict|yarns))$"
)

# a summary line does not end at "Fig. 7" or "Rec. 709"
_autosummary.WELL_KNOWN_ABBREVIATIONS = (*_autosummary.WELL_KNOWN_ABBREVIATIONS, "Fig.", "Figs.", "Rec.", "Sec.")

# The module pages are written here, before autosummary runs: each object gets one
# page, under the first module of API_MODULES that exports it (its public name);
# the other modules that re-export it link to that page.
API_MODULES = {
    "The table and its file": ["cdbrdf", "cdbrdf.table", "cdbrdf.sources", "cdbrdf.grid", "cdbrdf.io", "cdbrdf.interp",
                               "cdbrdf.errors"],
    "Fabrics": ["cdbrdf.materials", "cdbrdf.synth", "cdbrdf.synth.metrics", "cdbrdf.fit"],
    "Measurement and import": ["cdbrdf.measure", "cdbrdf.rig", "cdbrdf.importers", "cdbrdf.bend", "cdbrdf.images"],
    "Geometry and rendering": ["cdbrdf.frames", "cdbrdf.mesh", "cdbrdf.render"],
    "Exchange: glTF 2.0 and MaterialX": [
        "cdbrdf.gltf_table",
        "cdbrdf.export.gltf",
        "cdbrdf.export.fallback",
        "cdbrdf.export.tangents",
        "cdbrdf.export.materialx",
        "cdbrdf.view.gltf_page",
    ],
    "Colour, figures, the viewer, the demo": [
        "cdbrdf.colour",
        "cdbrdf.spectral",
        "cdbrdf.plot",
        "cdbrdf.view.export",
        "cdbrdf.view.server",
        "cdbrdf.view.asset",
        "cdbrdf.demo",
    ],
}


def _write_api_pages(out: Path) -> set[str]:
    """Write one page per module of API_MODULES; return the names numpydoc does not validate."""
    import importlib
    import inspect

    out.mkdir(parents=True, exist_ok=True)
    owner: dict[object, str] = {}
    plain: set[str] = set()  # constants (a one-line comment) and named-tuple fields
    kinds = ("Classes", "Functions", "Exceptions", "Constants")
    for modules in API_MODULES.values():
        for modname in modules:
            module = importlib.import_module(modname)
            own: dict[str, list[str]] = {k: [] for k in kinds}
            linked: list[str] = []
            for name in module.__all__:
                obj = getattr(module, name)
                if inspect.ismodule(obj) or name.startswith("__"):
                    continue
                if inspect.isclass(obj):
                    kind = "Exceptions" if issubclass(obj, BaseException) else "Classes"
                elif inspect.isroutine(obj):
                    kind = "Functions"
                else:
                    kind = "Constants"
                # a constant is the same one only under the same name (small values are shared objects)
                key = (id(obj), name) if kind == "Constants" else id(obj)
                if kind != "Constants" or not isinstance(obj, (int, float, str, bool, type(None))):
                    if key in owner:
                        linked.append(owner[key])
                        continue
                    owner[key] = f"{modname}.{name}"
                own[kind].append(name)
                if kind == "Constants":
                    plain.add(f"{modname}.{name}")
                plain.update(f"{modname}.{name}.{field}" for field in getattr(obj, "_fields", ()))
            lines = [modname, "=" * len(modname), "", f".. automodule:: {modname}", "   :no-members:", ""]
            lines += [f".. currentmodule:: {modname}", ""]
            for kind in kinds:
                if own[kind]:
                    lines += [kind, "-" * len(kind), "", ".. autosummary::", "   :toctree: .", "   :nosignatures:", ""]
                    lines += [f"   {name}" for name in own[kind]] + [""]
            if linked:
                title = "Also exported here"
                lines += [title, "-" * len(title), "", ".. autosummary::", "   :nosignatures:", ""]
                lines += [f"   ~{full}" for full in linked] + [""]
            (out / f"{modname}.rst").write_text("\n".join(lines), encoding="utf-8")
    return plain


numpydoc_validation_exclude = {f"^{re.escape(name)}$" for name in _write_api_pages(DOCS / "api" / "generated")}
numpydoc_validation_exclude.add(_UNDOCUMENTED)



def _def_line_or_none(self):  # noqa: ANN001, ANN202
    """numpydoc's source line of an object, None for one made without ``def`` (``property(...)``)."""
    try:
        return _numpydoc_def_line(self)
    except StopIteration:
        return None


_numpydoc_def_line = _numpydoc_validate.Validator.source_file_def_line.fget
_numpydoc_validate.Validator.source_file_def_line = property(_def_line_or_none)

# -- the guides (MyST) --------------------------------------------------------------
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath", "deflist"]
suppress_warnings = ["myst.xref_missing"] if os.environ.get("CDBRDF_DOCS_LAX") == "1" else []

# -- the gallery ----------------------------------------------------------------------
# Every example runs on each build; an example that fails fails the build. The RGL
# example reads CDBRDF_SHARED_DATA (set by scripts/docs.sh when the shared test data
# are found) and writes a small file of its own otherwise.
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "abort_on_example_error": False,  # every broken example is reported; -W fails the build
    "only_warn_on_example_error": False,
    "remove_config_comments": True,
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reference_url": {},
    "show_memory": False,
    "plot_gallery": os.environ.get("CDBRDF_DOCS_PLOT_GALLERY", "True"),
}

# -- HTML -------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"cdbrdf {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False


def _drop_type_docstrings(app, what, name, obj, options, lines):  # noqa: ANN001, ANN202
    """Show no docstring for a constant rather than the docstring of its type (an array's)."""
    if what not in ("data", "attribute") or not lines:
        return
    for doc in (type(obj).__doc__, getattr(obj, "__doc__", None)):
        if isinstance(doc, str) and doc.strip() and lines[0].strip() == doc.strip().splitlines()[0].strip():
            lines.clear()
            return


def _comment_of_reexported_constant(app, what, name, obj, options, lines):  # noqa: ANN001, ANN202
    """Give a re-exported constant the ``#:`` comment of the module that defines it."""
    if what != "data" or lines:
        return
    from sphinx.errors import PycodeError
    from sphinx.pycode import ModuleAnalyzer

    attr = name.rpartition(".")[2]
    for modname in sorted(m for m in sys.modules if m.startswith("cdbrdf.")):
        if getattr(sys.modules[modname], attr, None) is not obj:
            continue
        try:
            docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except PycodeError:
            continue
        if ("", attr) in docs:
            lines[:] = [line for line in docs[("", attr)] if line.strip()]
            return


def setup(app):  # noqa: ANN001, ANN201
    app.connect("autodoc-process-docstring", _drop_type_docstrings, priority=100)
    app.connect("autodoc-process-docstring", _comment_of_reexported_constant, priority=200)
