"""How a sensor's tracker differs between people and between one person's sessions.

A profile's tracker parameters describe its typical person. Its population (the ``[population]``
table of a profile) says how far other people, and other sessions of one person, stray from it:
per *family* of parameters one factor on a log scale, drawn once per person and once per session
and added,

    f = mean + person_sd * t_person + session_sd * z_session,

``z_session`` standard normal and ``t_person`` Student-t with ``person_df`` degrees of freedom (normal
when infinite, as :mod:`scenarios.sensors.fit_population` fits it); both are clipped to
+-:data:`CLIP` (no person is drawn beyond what the model can mean). The person part is also where the simulated person's systematic errors come from
(:func:`person_streams`). The factor applies to every joint group (:func:`apply_factors`):

- ``noise``: white jitter and wobble sizes times ``exp(f)``;
- ``bias``: the view bias range times ``exp(f)``;
- ``bone``: the bone-length spread: the body scale's ``body_scale_sd`` times ``exp(f)`` (at most 0.2) for a
  tracker with one, else ``1 - bone_rigidity`` (rigidity kept in [0, 0.99]);
- ``confidence``: the probability of a low-confidence report (visible and hidden joints) shifted by
  ``f`` on the arcsine-square-root scale (:func:`confidence_scale`).

``mean`` is the population's mean person relative to the typical parameters (0 when they are the
mean person). The families are the tracker traits that the truth-free statistics of real sessions
separate (jitter and fluctuating residual; steady residual; bone-length spread; confidence share).

A population may also know *labs* (``[population.labs.<name>]``): where the people it was fitted on
came from several labs (their sensors' set-up and the recordings' processing), each lab's people have
a mean of their own, and around it the spread between people of one lab. A person of a known lab is
drawn from that lab's population (:meth:`Population.for_lab`); a person of another lab, or of none
named, from the population itself, whose person spread then holds the labs' differences too.
"""

from __future__ import annotations

import dataclasses
import enum
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from fusion.errors import BadInputError
from fusion.recording import check_lab
from sim.tracker_noise import TrackerNoise

CLIP = 3.0
"""Largest magnitude of a standardised person or session draw."""

MAX_LOG_SD = 3.0
"""Largest person or session spread [log units; radians of the arcsine scale for confidence] a
population may hold: a factor of e^3 = 20 in one standard deviation; fits beyond it are held there
(with a note)."""


def confidence_scale(p: np.ndarray | float) -> np.ndarray:
    """``arcsin(sqrt(p))`` [rad] of a probability or share ``p`` in [0, 1]: the scale the confidence
    family shifts on.

    It is the variance-stabilising transform of a binomial share: a share's sampling spread on it is
    about the same over [0, 1], where the log-odds stretch the shares near 0 and 1 without bound.
    Fitted on the log-odds, one KIMORE recording with 0.3 % of its joint samples below confidence 2
    (the others 7-9 %) set the Kinect v2's spreads at 1.8 / 2.2 between people / sessions, and a
    person drawn one spread up reported under half of its joints at confidence 2, where every real
    recording fitted reported 81-99.7 %.
    """
    return np.arcsin(np.sqrt(np.clip(p, 0.0, 1.0)))


def from_confidence_scale(a: np.ndarray | float) -> np.ndarray:
    """The probability whose :func:`confidence_scale` is ``a`` (clipped to [0, pi / 2])."""
    return np.sin(np.clip(a, 0.0, 0.5 * np.pi)) ** 2


class Family(enum.Enum):
    """Tracker parameters that vary together between people (see the module docstring)."""

    NOISE = "noise"
    BIAS = "bias"
    BONE = "bone"
    CONFIDENCE = "confidence"


@dataclass(frozen=True)
class Spread:
    """One family's factor: ``mean``, ``person_sd`` and ``session_sd`` on its scale (natural log, or
    :func:`confidence_scale` for ``confidence``), and ``person_df``, the degrees of freedom of the person draw
    (``inf``: normal)."""

    mean: float = 0.0
    person_sd: float = 0.0
    session_sd: float = 0.0
    person_df: float = float("inf")

    def __post_init__(self) -> None:
        if not np.isfinite(self.mean):
            raise BadInputError(f"a population mean must be finite, got {self.mean}")
        for name in ("person_sd", "session_sd"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0 <= v <= MAX_LOG_SD):
                raise BadInputError(f"population {name} must lie in [0, {MAX_LOG_SD:g}] (log units), got {v}")
        if not self.person_df >= 1:
            raise BadInputError(f"population person_df must be >= 1 (inf: normal), got {self.person_df}")

    def text(self, digits: int = 3) -> str:
        """``+0.123, 0.456 (6)``: the mean, a new person's scale and its degrees of freedom, for reports."""
        return f"{self.mean:+.{digits}f}, {self.person_sd:.{digits}f} ({self.person_df:g})"


@dataclass(frozen=True)
class Population:
    """Per family its :class:`Spread`; a family not given does not vary. ``labs``: lab name ->
    the population of that lab's people (module docstring; a lab's own population knows no labs)."""

    spreads: Mapping[Family, Spread]
    labs: Mapping[str, "Population"] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "spreads", MappingProxyType({Family(f): s for f, s in self.spreads.items()}))
        for name, lab in self.labs.items():
            check_lab(name)
            if not isinstance(lab, Population) or lab.labs:
                raise BadInputError(f"lab {name!r}: its population must be a Population that knows no labs")
        object.__setattr__(self, "labs", MappingProxyType(dict(self.labs)))

    def for_lab(self, lab: str | None) -> "Population":
        """The population a person of ``lab`` is drawn from: the lab's when known, else this one (a
        person of a lab the fit did not see, or of none named)."""
        return self.labs.get(lab, self) if lab is not None else self

    def spread(self, family: Family) -> Spread:
        """The family's spread (none when not given)."""
        return self.spreads.get(family, Spread())

    def lab_words(self, lab: str | None) -> str:
        """Words to follow "the population" on whom a person of ``lab`` is drawn from ('' for no lab)."""
        if lab in self.labs:
            return f", of lab {lab}'s people"
        if lab is not None and self.labs:
            return f" (lab {lab} is not among its labs, {', '.join(self.labs)}: a person of a lab it was not fitted on)"
        return ""

    def draw_person(self, rng: np.random.Generator) -> dict[Family, float]:
        """One person's factors: ``mean + person_sd * t`` per family (one draw per family, in
        :class:`Family` order; ``t`` Student-t with ``person_df``, clipped to +-:data:`CLIP`)."""
        out = {}
        for f, z in zip(Family, rng.standard_normal(len(Family))):
            s = self.spread(f)
            if np.isfinite(s.person_df):  # t = z / sqrt(chi2_df / df), its own draw per family
                z = z / np.sqrt(rng.chisquare(s.person_df) / s.person_df)
            out[f] = s.mean + s.person_sd * float(np.clip(z, -CLIP, CLIP))
        return out

    def draw_session(self, person: Mapping[Family, float], rng: np.random.Generator) -> dict[Family, float]:
        """One session of ``person``: ``person + session_sd * z`` per family (``z`` clipped to +-:data:`CLIP`)."""
        z = np.clip(rng.standard_normal(len(Family)), -CLIP, CLIP)
        return {f: person.get(f, 0.0) + self.spread(f).session_sd * float(zf) for f, zf in zip(Family, z)}


def labelled_seed(seed: int, label: str) -> int:
    """A seed for the simulated person or session named ``label`` under the run seed ``seed``: the same in
    every run and process, independent for different labels."""
    return int(np.random.SeedSequence([int(seed), zlib.crc32(label.encode())]).generate_state(1)[0])


def person_streams(person_seed: int, n_cameras: int) -> tuple[np.random.Generator, np.random.Generator,
                                                             list[np.random.Generator]]:
    """A simulated person's random streams: its population factors, its tracker's body-model bias, and
    per camera (by its place in the rig) the view bias that camera sees on it. The same person seen
    from the same camera places keeps its systematic errors from session to session."""
    factors, model, *views = np.random.SeedSequence(int(person_seed)).spawn(2 + n_cameras)
    return np.random.default_rng(factors), np.random.default_rng(model), [np.random.default_rng(v) for v in views]


def session_tracker(tracker: TrackerNoise, population: Population, person_seed: int, n_cameras: int,
                    session_rng: np.random.Generator) -> TrackerNoise:
    """``tracker`` as the person of ``person_seed`` (factors from :func:`person_streams`) on one session
    drawn with ``session_rng``."""
    person = population.draw_person(person_streams(person_seed, n_cameras)[0])
    return apply_factors(tracker, population.draw_session(person, session_rng))


def apply_factors(tracker: TrackerNoise, factors: Mapping[Family, float]) -> TrackerNoise:
    """``tracker`` with the factors of :class:`Family` applied to every joint group (module docstring)."""
    f = {fam: float(factors.get(fam, 0.0)) for fam in Family}
    scale = {fam: float(np.exp(f[fam])) for fam in (Family.NOISE, Family.BIAS, Family.BONE)}

    def shifted(p: float) -> float:  # a certain share (0 or 1) stays certain
        if f[Family.CONFIDENCE] == 0 or not 0 < p < 1:
            return p
        return float(from_confidence_scale(confidence_scale(p) + f[Family.CONFIDENCE]))

    templated = tracker.body_scale_sd > 0  # the bones' spread is the body scale's

    def rigidity(r: float) -> float:
        if f[Family.BONE] == 0 or templated:
            return r
        return float(np.clip(1 - (1 - r) * scale[Family.BONE], 0.0, 0.99))

    groups = {}
    for g, n in tracker.groups.items():
        groups[g] = dataclasses.replace(
            n, jitter_m=n.jitter_m * scale[Family.NOISE], wobble_m=n.wobble_m * scale[Family.NOISE],
            bias_m=tuple(b * scale[Family.BIAS] for b in n.bias_m),
            bone_rigidity=rigidity(n.bone_rigidity),
            low_confidence=tuple(shifted(p) for p in n.low_confidence),
            hidden_low_confidence=shifted(n.hidden_low_confidence))
    return dataclasses.replace(tracker, groups=groups, body_scale_sd=min(tracker.body_scale_sd * scale[Family.BONE], 0.2))


SPREAD_FIELDS = ("mean", "person_sd", "session_sd", "person_df")
"""The fields of a :class:`Spread`, in a population table's key order (``<family>_<field>``)."""


def population_keys(population: Population | None = None) -> list[str]:
    """The ``population.<family>_<field>`` keys of a profile's population table, then each known lab's
    ``population.labs.<lab>.<family>_<field>``: of the families ``population`` gives, or of every
    family."""
    families = list(Family) if population is None else [f for f in Family if f in population.spreads]
    keys = [f"population.{f.value}_{k}" for f in families for k in SPREAD_FIELDS]
    for name, lab in ({} if population is None else population.labs).items():
        keys += [k.replace("population.", f"population.labs.{name}.", 1) for k in population_keys(lab)]
    return keys


def population_tables(population: Population) -> list[str]:
    """TOML lines of ``[population]`` and its ``[population.labs.<lab>]`` tables (as read by
    :func:`population_from_table`)."""
    def lines(pop: Population) -> list[str]:
        return [f"{f.value}_{k} = {float(getattr(pop.spread(f), k))!r}"
                for f in Family if f in pop.spreads for k in SPREAD_FIELDS]

    out = ["[population]", *lines(population)]
    for name, lab in population.labs.items():
        out += ["", f"[population.labs.{name}]", *lines(lab)]
    return out


def population_from_table(table: Mapping[str, object], where: str, *, name: str = "population") -> Population:
    """A :class:`Population` from a profile's ``[population]`` table (keys ``<family>_mean``,
    ``<family>_person_sd``, ``<family>_session_sd``, ``<family>_person_df``, each family complete;
    ``inf`` degrees of freedom: a normal person draw), with its ``labs`` sub-tables, one per lab, of the
    same keys (``name``: the table read, a lab's ``population.labs.<lab>``, which holds no labs)."""
    allowed = [k.split(".", 1)[1] for k in population_keys()]
    table = dict(table)
    lab_tables = table.pop("labs", {}) if name == "population" else {}
    if not isinstance(lab_tables, Mapping) or not all(isinstance(t, Mapping) for t in lab_tables.values()):
        raise BadInputError(f"{where} [population.labs]: give one table per lab, [population.labs.<name>]")
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise BadInputError(f"{where} [{name}]: unknown key {unknown[0]!r}; allowed: {', '.join(allowed)}")
    spreads = {}
    for fam in Family:
        keys = [f"{fam.value}_{k}" for k in SPREAD_FIELDS]
        given = [k for k in keys if k in table]
        if given and len(given) != len(keys):
            raise BadInputError(f"{where} [{name}]: give all of {', '.join(keys)} or none")
        if not given:
            continue
        values = [table[k] for k in keys]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            raise BadInputError(f"{where} [{name}]: {', '.join(keys)} must be numbers")
        spreads[fam] = Spread(*(float(v) for v in values))
    return Population(spreads, {lab: population_from_table(t, where, name=f"population.labs.{lab}")
                                for lab, t in lab_tables.items()})
