"""The models a flat measurement is fitted with: which of their parameters are free, their physical bounds.

Each :class:`FitModel` names its free parameters (:class:`Parameter`: bounds
from physics, linear or logarithmic, a colour being three channels that each
change only their own channel of the BRDF), turns values of them into the
model's own parameter set and evaluates the model at direction pairs. The
registry :data:`FIT_MODELS`:

- ``woven``: :class:`cdbrdf.synth.cloth.ClothModel` (a weave of yarns of
  fibres: the colour of each yarn, the fibres' surface reflection, gloss,
  sheen and isotropic share, the yarns' cover and flatness);
- ``pile``: :class:`cdbrdf.synth.pile.PileModel` (fibres standing on a
  ground: the fibres' and the ground's colours, the pile's density, the
  fibres' spread, gloss and surface reflection, the gaps' size);
- ``sheen``: the analytic baseline of :mod:`cdbrdf.fit.sheen` (Lambert and
  the Charlie sheen lobe).

What a flat measurement cannot tell is fixed, and the fit result says so
(:attr:`FitModel.fixed`): a flat BRDF does not change when every length of
the fabric is scaled together (the height field of the weave, the pile's
slabs), so the counts, the yarn and fibre sizes, the pile's height and the
thickness keep the values of a typical fabric of the kind (the parameter
sets' defaults, a 33 ends/cm plain weave and a 1.5 mm cut pile); they set how
strongly bending acts (``cdbrdf bend`` records them). The weave itself is
chosen among :data:`WEAVE_CHOICES` by the fit.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OptionError
from .data import ISOTROPIC_TURNS_DEG, FitData
from .sheen import SheenParams, sheen_brdf

__all__ = ["Parameter", "FitModel", "WovenFit", "PileFit", "SheenFit", "FIT_MODELS", "WEAVE_CHOICES", "QUALITIES",
           "fit_model"]

#: Weaves the ``woven`` fit chooses from (registered names of :data:`cdbrdf.synth.WEAVES`).
WEAVE_CHOICES: tuple[str, ...] = ("plain", "twill_3_1", "satin_5")
#: Integration settings: ``"fit"`` (coarse, while fitting) and ``"full"`` (the model's own defaults).
QUALITIES: tuple[str, ...] = ("fit", "full")
#: The woven model's integration points and texels while fitting (its own defaults: 4181 and 192;
#: the coarse setting differs from them by a median 1 %, 90th percentile 2 %, at random direction pairs).
_WOVEN_FIT_QUALITY = {"points": 1000, "texels": 96}
#: Woven models a fit keeps to recolour (its structures last evaluated).
_WOVEN_CACHE = 8


@dataclass(frozen=True)
class Parameter:
    """A free parameter of a fit.

    Attributes
    ----------
    name
        Its name in the fit result.
    lower, upper
        Bounds (physical units).
    unit
        Unit, for the record.
    channels
        3 for a colour (each channel changes only its own channel of the
        BRDF), else 1.
    log
        Fitted as its logarithm (a positive quantity spanning decades).
    why
        Where the bounds come from.
    """

    name: str
    lower: float
    upper: float
    unit: str = ""
    channels: int = 1
    log: bool = False
    why: str = ""

    def to_internal(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """Physical value(s) -> the fit's variable(s).

        Parameters
        ----------
        v
            Physical value(s).

        Returns
        -------
        numpy.ndarray
            Their logarithm for a logarithmic parameter, else themselves.
        """
        return np.log(v) if self.log else np.asarray(v, dtype=np.float64)

    def to_physical(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """The fit's variable(s) -> physical value(s).

        Parameters
        ----------
        u
            The fit's variable(s).

        Returns
        -------
        numpy.ndarray
            The physical value(s).
        """
        return np.exp(u) if self.log else np.asarray(u, dtype=np.float64)

    def bounds(self) -> tuple[float, float]:
        """Bounds of the fit's variable.

        Returns
        -------
        tuple of float
            ``(lower, upper)`` (their logarithms for a logarithmic parameter).
        """
        lo, hi = (math.log(self.lower), math.log(self.upper)) if self.log else (self.lower, self.upper)
        return lo, hi


_ALBEDO = "an albedo: at most all the light, [0, 1]"


class FitModel(ABC):
    """A model with free parameters, evaluated at a flat measurement's direction pairs (abstract).

    Attributes
    ----------
    name
        Registry name (:data:`FIT_MODELS`).
    description
        One line on what the model is.
    parameters
        The free parameters.
    channels_independent
        Whether each channel of a colour changes only its own channel of the
        BRDF (then the Jacobian steps the three channels together, one
        evaluation per colour; ``tests/test_fit.py`` checks the claim).
    max_evaluations
        Model evaluations a fit takes at most by default (a Jacobian by
        finite differences costs one per parameter and one per colour,
        Broyden's updates between them none).
    """

    name: str = ""
    description: str = ""
    parameters: tuple[Parameter, ...] = ()
    channels_independent: bool = True
    max_evaluations: int = 60

    @property
    def fixed(self) -> dict[str, Any]:
        """Parameters held fixed, with the reason (JSON-ready)."""
        return {}

    @abstractmethod
    def initial(self, data: FitData) -> dict[str, Any]:
        """A start for the fit from the measurement.

        Parameters
        ----------
        data
            The measurement.

        Returns
        -------
        dict
            A value per free parameter.
        """

    @abstractmethod
    def build(self, values: Mapping[str, Any], *, quality: str = "full") -> Any:
        """The model with these values.

        Parameters
        ----------
        values
            A value per free parameter.
        quality
            One of :data:`QUALITIES`.

        Returns
        -------
        object
            An object with ``evaluate(theta_v, phi_v, theta_l, phi_l, kappa)``.
        """

    @abstractmethod
    def model_params(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """The model's whole parameter set with these values.

        Parameters
        ----------
        values
            A value per free parameter.

        Returns
        -------
        dict
            JSON-ready, every parameter of the model.
        """

    @property
    def bends(self) -> bool:
        """Whether the model depends on curvature (can bend a measurement)."""
        return True

    @property
    def label(self) -> str:
        """What tells this variant from the others (:meth:`variants`): the name, the woven model's weave."""
        return self.name

    def variants(self) -> list[FitModel]:
        """The discrete choices a fit tries before it fits one of them in full (default: only this model).

        Returns
        -------
        list of FitModel
            The woven model with ``weave="auto"``: one per weave of :data:`WEAVE_CHOICES`.
        """
        return [self]

    def evaluate(self, values: Mapping[str, Any], data: FitData, *, quality: str = "fit",
                 kappa: float = 0.0) -> NDArray[np.float64]:
        """The model at the pairs of ``data``, averaged over turns when ``data`` is isotropic.

        Parameters
        ----------
        values
            A value per free parameter.
        data
            The direction pairs (and whether the measurement is isotropic).
        quality
            One of :data:`QUALITIES`.
        kappa
            Curvature, 1/mm.

        Returns
        -------
        numpy.ndarray
            ``(n, 3)``, sr^-1.
        """
        m = self.build(values, quality=quality)
        tv, pv, tl, pl = data.angles()
        turns = ISOTROPIC_TURNS_DEG if data.isotropic else (0.0,)
        n = tv.size
        a = np.repeat(np.asarray(turns), n)
        f = m.evaluate(np.tile(tv, len(turns)), np.tile(pv, len(turns)) + a, np.tile(tl, len(turns)),
                       np.tile(pl, len(turns)) + a, kappa)
        return np.asarray(f, dtype=np.float64).reshape(len(turns), n, 3).mean(axis=0)


def _start_colour(data: FitData, gain: float = 1.0) -> tuple[float, float, float]:
    """A first colour from the measurement: pi x the median BRDF at moderate angles, times ``gain``, in [0.02, 0.95]."""
    near = (data.theta_v <= 50) & (data.theta_l <= 50)
    v = data.values[near] if np.count_nonzero(near) >= 8 else data.values
    c = np.clip(math.pi * np.median(v, axis=0) * gain, 0.02, 0.95)
    return (float(c[0]), float(c[1]), float(c[2]))


class WovenFit(FitModel):
    """The woven-cloth model (:class:`cdbrdf.synth.cloth.ClothModel`) with one weave, or ``"auto"``.

    With ``weave="auto"`` a fit probes every weave of :data:`WEAVE_CHOICES`
    briefly and fits the best one in full (:meth:`variants`).
    """

    name = "woven"
    description = ("woven cloth (cdbrdf.synth.cloth): yarns of fibres on a weave, microcylinder fibre scattering "
                   "(Sadeghi et al. 2013), shadowing and masking by the yarns")
    parameters = (
        Parameter("warp_rgb", 0.0, 1.0, "", 3, why=_ALBEDO),
        Parameter("weft_rgb", 0.0, 1.0, "", 3, why=_ALBEDO + "; also what shows through the gaps"),
        Parameter("specular", 0.0, 1.0, "", why="weight of the Fresnel surface reflection, none to all of it"),
        Parameter("gloss_deg", 2.0, 40.0, "degree",
                  why="width of the fibre's surface reflection: polished filament (2) to rough staple (40)"),
        Parameter("sheen_deg", 3.0, 60.0, "degree", why="width of the forward-scattered sheen of the fibres"),
        Parameter("isotropic", 0.0, 1.0, "", why="share of the volume scattering that is isotropic"),
        Parameter("flatness", 0.25, 1.0, "",
                  why="yarn height over width: flattened 4:1 (0.25) to round (1), sets the crimp angle"),
    )
    # a model evaluation costs about 0.5 s (the fibres' lobe normalisation): 12 for each weave's probe,
    # 36 for the chosen one
    max_evaluations = 72
    # yarn width over spacing, held: the gaps show at grazing angles only, a flat measurement hardly sees them
    cover = 0.9

    def __init__(self, weave: str = "auto") -> None:
        from ..synth.weave import WEAVES

        if weave != "auto" and weave not in WEAVES:
            raise OptionError(f"weave: {weave!r} is not one of auto, {', '.join(WEAVES)}")
        self.weave = weave
        # models by everything but the colours: a colour change recolours one of them (its geometry and
        # lobes kept, ClothModel.recoloured) instead of building the cloth again
        self._models: dict[tuple[Any, ...], Any] = {}

    @property
    def label(self) -> str:
        return self.weave

    def variants(self) -> list[FitModel]:
        if self.weave != "auto":
            return [self]
        return [WovenFit(w) for w in WEAVE_CHOICES]

    @property
    def fixed(self) -> dict[str, Any]:
        from ..synth.cloth import ClothParams

        p = ClothParams()
        return {
            "weave": self.weave,
            "warp_pitch_mm": p.warp_pitch_mm, "weft_pitch_mm": p.weft_pitch_mm, "thickness_mm": p.thickness_mm,
            "warp_along": p.warp_along, "ior": p.ior, "footprint_mm": p.footprint_mm, "cover": self.cover,
            "reason": "a flat BRDF does not change when every length is scaled together: the counts and the "
                      "thickness of a typical plain-woven fabric (33 ends/cm, 0.5 mm) are kept; they set how "
                      "strongly bending acts; the cover (yarn width over spacing) is held at 0.9: the gaps show at "
                      "grazing angles only",
        }

    def initial(self, data: FitData) -> dict[str, Any]:
        c = _start_colour(data, 1.6)
        return {"warp_rgb": c, "weft_rgb": c, "specular": 0.3, "gloss_deg": 12.0, "sheen_deg": 20.0,
                "isotropic": 0.7, "flatness": 0.5}

    def cloth_params(self, values: Mapping[str, Any], *, quality: str = "full") -> Any:
        """The :class:`~cdbrdf.synth.cloth.ClothParams` of ``values``.

        Parameters
        ----------
        values
            A value per free parameter.
        quality
            One of :data:`QUALITIES`.

        Returns
        -------
        ClothParams
            The cloth.
        """
        from ..synth.cloth import ClothParams

        if self.weave == "auto":
            raise OptionError("weave: 'auto' is chosen by the fit; give a weave to build the model")
        base = ClothParams(name="fitted woven", weave=self.weave)
        ww = self.cover * base.warp_pitch_mm
        wf = self.cover * base.weft_pitch_mm
        fl = float(values["flatness"])
        extra = _WOVEN_FIT_QUALITY if quality == "fit" else {}
        return base.replace(
            warp_rgb=tuple(values["warp_rgb"]), weft_rgb=tuple(values["weft_rgb"]),
            backing_rgb=tuple(values["weft_rgb"]),
            warp_specular=float(values["specular"]), weft_specular=float(values["specular"]),
            warp_gloss_deg=float(values["gloss_deg"]), weft_gloss_deg=float(values["gloss_deg"]),
            warp_sheen_deg=float(values["sheen_deg"]), weft_sheen_deg=float(values["sheen_deg"]),
            warp_isotropic=float(values["isotropic"]), weft_isotropic=float(values["isotropic"]),
            warp_width_mm=ww, weft_width_mm=wf, warp_height_mm=fl * ww, weft_height_mm=fl * wf, **extra)

    def build(self, values: Mapping[str, Any], *, quality: str = "full") -> Any:
        from ..synth.cloth import ClothModel

        p = self.cloth_params(values, quality=quality)
        key = (quality, *(float(values[k]) for k in ("specular", "gloss_deg", "sheen_deg", "isotropic", "flatness")))
        base = self._models.get(key)
        if base is None or not hasattr(base, "recoloured"):
            base = ClothModel(p)
            if len(self._models) >= _WOVEN_CACHE:
                self._models.pop(next(iter(self._models)))
            self._models[key] = base
            return base
        return base.recoloured(warp_rgb=p.warp_rgb, weft_rgb=p.weft_rgb, backing_rgb=p.backing_rgb)

    def model_params(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return self.cloth_params(values).to_dict()


class PileFit(FitModel):
    """The pile model (:class:`cdbrdf.synth.pile.PileModel`), cut fibres."""

    name = "pile"
    # each channel is its own (model 2.0: the fibres' normalisation and multiple scattering per channel)
    channels_independent = True
    # a model evaluation costs about 0.05 s
    max_evaluations = 80
    description = ("pile fabric (cdbrdf.synth.pile): fibres standing on a ground, a fibre medium with "
                   "correlated shadowing, multiple scattering in the pile and with the ground (model 2.0)")
    parameters = (
        Parameter("fibre_rgb", 0.0, 1.0, "", 3, why=_ALBEDO),
        Parameter("ground_rgb", 0.0, 1.0, "", 3, why=_ALBEDO),
        Parameter("strands_per_mm2", 5.0, 5000.0, "1/mm^2", log=True,
                  why="fibres per ground area for 15 um fibres 1.5 mm high: an optical depth of about 0.1 "
                      "(sparse) to 100 (dense felt or velvet)"),
        Parameter("spread_deg", 0.0, 60.0, "degree", why="tilt of the fibres about the normal (model's range)"),
        Parameter("fibre_gloss_deg", 2.0, 30.0, "degree",
                  why="longitudinal width of the fibres' surface reflection (Marschner et al. 2003: 5-10)"),
        Parameter("fibre_specular", 0.0, 1.0, "", why="weight of the Fresnel surface reflection, none to all of it"),
        Parameter("correlation_mm", 0.005, 1.0, "mm", log=True,
                  why="size of the gaps between tufts (the hot spot), a fibre's width to a loop's"),
    )

    @property
    def fixed(self) -> dict[str, Any]:
        from ..synth.pile import PileParams

        p = PileParams()
        return {
            "kind": p.kind, "pile_height_mm": p.pile_height_mm, "strand_diameter_mm": p.strand_diameter_mm,
            "lean_deg": p.lean_deg, "ior": p.ior,
            "reason": "a flat BRDF does not change when every length is scaled together: the pile's height and "
                      "fibre diameter of a typical cut pile (1.5 mm, 15 um) are kept and its density fitted; "
                      "an isotropic measurement has no lean",
        }

    def initial(self, data: FitData) -> dict[str, Any]:
        c = _start_colour(data, 1.4)
        return {"fibre_rgb": c, "ground_rgb": c, "strands_per_mm2": 300.0, "spread_deg": 20.0,
                "fibre_gloss_deg": 8.0, "fibre_specular": 0.5, "correlation_mm": 0.1}

    def pile_params(self, values: Mapping[str, Any]) -> Any:
        """The :class:`~cdbrdf.synth.pile.PileParams` of ``values``.

        Parameters
        ----------
        values
            A value per free parameter.

        Returns
        -------
        PileParams
            The pile fabric.
        """
        from ..synth.pile import PileParams

        return PileParams(name="fitted pile").replace(
            fibre_rgb=tuple(values["fibre_rgb"]), ground_rgb=tuple(values["ground_rgb"]),
            strands_per_mm2=float(values["strands_per_mm2"]), spread_deg=float(values["spread_deg"]),
            fibre_gloss_deg=float(values["fibre_gloss_deg"]), fibre_specular=float(values["fibre_specular"]),
            correlation_mm=float(values["correlation_mm"]))

    def build(self, values: Mapping[str, Any], *, quality: str = "full") -> Any:
        from ..synth.pile import PileModel

        return PileModel(self.pile_params(values))

    def model_params(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return self.pile_params(values).to_dict()


class _Sheen:
    """The baseline as an object with the models' ``evaluate`` (curvature ignored)."""

    def __init__(self, params: SheenParams) -> None:
        self.params = params

    def evaluate(self, theta_v: Any, phi_v: Any, theta_l: Any, phi_l: Any, kappa: Any = 0.0) -> NDArray[np.float64]:
        return sheen_brdf(self.params, theta_v, phi_v, theta_l, phi_l)


class SheenFit(FitModel):
    """The analytic baseline (:mod:`cdbrdf.fit.sheen`): Lambert + Charlie sheen."""

    name = "sheen"
    description = ("analytic cloth baseline: Lambert + Charlie sheen (Estevez & Kulla 2017) with the "
                   "Neubelt-Pettineo visibility (Filament's cloth model)")
    parameters = (
        Parameter("diffuse_rgb", 0.0, 1.0, "", 3, why=_ALBEDO),
        Parameter("sheen_rgb", 0.0, 1.0, "", 3, why="the sheen's colour, [0, 1]"),
        Parameter("roughness", 0.02, 1.0, "", log=True, why="the Charlie distribution's alpha, (0, 1]"),
    )

    @property
    def bends(self) -> bool:
        return False

    def initial(self, data: FitData) -> dict[str, Any]:
        return {"diffuse_rgb": _start_colour(data, 0.9), "sheen_rgb": _start_colour(data, 0.5), "roughness": 0.5}

    def build(self, values: Mapping[str, Any], *, quality: str = "full") -> Any:
        return _Sheen(SheenParams(diffuse_rgb=tuple(values["diffuse_rgb"]), sheen_rgb=tuple(values["sheen_rgb"]),
                                  roughness=float(values["roughness"])))

    def model_params(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return self.build(values).params.to_dict()


#: The fit models by name: ``woven`` (one weave, see :func:`fit_model`), ``pile``, ``sheen`` (the baseline).
FIT_MODELS: Mapping[str, str] = MappingProxyType({
    "woven": WovenFit.description,
    "pile": PileFit.description,
    "sheen": SheenFit.description,
})


def fit_model(name: str, *, weave: str = "auto") -> FitModel:
    """The :class:`FitModel` of a registered name (:data:`FIT_MODELS`).

    Parameters
    ----------
    name
        ``"woven"``, ``"pile"`` or ``"sheen"``.
    weave
        The weave of the woven model (:data:`cdbrdf.synth.WEAVES`), or ``"auto"``: the fit probes each of
        :data:`WEAVE_CHOICES` and keeps the best.

    Returns
    -------
    FitModel
        The fit model.

    Raises
    ------
    OptionError
        For an unknown name (listing the valid ones).
    """
    if name == "woven":
        return WovenFit(weave)
    if name == "pile":
        return PileFit()
    if name == "sheen":
        return SheenFit()
    raise OptionError(f"model: {name!r} is not one of {', '.join(FIT_MODELS)}")
