r"""The lengths of a ``<clearance_pin>`` block judged against the mechanism's own geometry.

A length in the wrong unit is a valid number: a clearance file without its ``unit`` line read
in metres makes a 10 um play 10 m, a 30 mm journal 30 km, and every length of the file is wrong
by the same factor, so comparing them with each other shows nothing. Each length is compared
here with a size the block cannot change: the model's own geometry.

Reference sizes [m] (:mod:`~clearance_pin.model.reference_sizes`: all from the URDF or MJCF
placements, a URDF's primitive shapes and an MJCF's geoms, none from the block):

- the *part* of a joint: the largest distance between two points of either body it joins,
  the points being the body's joint centres (its own joint, the joints it carries), the frames
  on it (links, fixed joints, sites, the loop joints' frames) and its shapes' centres; or its
  largest shape;
- the *extent* of the mechanism: the largest distance of a joint or frame from the root at the
  drawn configuration, or the largest part, whichever is larger. It stands for a part whose
  size is not known (one joint centre only), and is the reference of a force point;
- a length dimension's nominal size (the joint origin along its direction; the extent for an
  offset of nominal 0) and the ISO 286 IT1 tolerance at that size; a prismatic joint's largest
  URDF limit (of ``|lower|``, ``|upper|``) when it has limits.

Each kind of length has a band of ratios to its reference that real mechanisms fill:

==========================  ===========================  ====================================
length                      normal ratio                 why
==========================  ===========================  ====================================
play (radial, axial,        up to 1e-2 of the part;      loose fits; ISO 286 fits (H6/g5 ..
``play_z``; diametral / 2)  1e-4 .. 1e-2 of its own      H11/c11 at 30 mm) give 1e-4 .. 5e-3
                            journal or block length      of the journal
journal or block length,    1e-2 .. 3 of the part        a bearing is shorter than its part;
``width``, ``height``                                    a few times the part is already odd
force point (its distance   1e-2 .. 1 of the extent      a load acts on the mechanism
from the link frame)
nominal ``q`` of a          1e-2 .. 1 of its largest     a slide stays on its guide
prismatic joint             URDF limit (of the extent)
tolerance T (full width)    IT1 at the nominal size ..   IT01, IT0 are gauge blocks; beyond
of a length dimension       0.2 of the nominal size      T/2 = 10 %: plausibility's warning
==========================  ===========================  ====================================

A journal is a reference of its plays only when it is in proportion itself (a journal in the
wrong unit is named, not the plays measured with it). A play is not judged too fine against its
part: a very fine play breaks nothing here, and one negligible against the others is ruled on by
:mod:`~clearance_pin.equilibrium.negligible_play`. A zero is never judged, nor a force point
within round-off of its frame.

A value outside its band by :data:`OUT_OF_PROPORTION` (10x) or more is out of proportion. How
sure that is decides the outcome:

- :class:`~clearance_pin.errors.ModelError` when the evidence leaves no design that explains the
  value: too large by :data:`CERTAIN` (1000x, a whole unit step beyond the widest normal value: a
  play ten times its part, a journal 3000 times it), or a journal or block that small; or too
  large at all in a clearance *file* without a ``unit`` line, whose user never said the lengths
  were metres (the docs' own UR5 file without its ``unit = "um"`` line gave a 25.6 m tool
  displacement with ``ok=True``; a URDF is SI by its own rules, so a block inside one is warned,
  and a dict is SI by the API's); or when every journal and block length of the block (two at
  least) is out of proportion and all would be normal in one same other unit: then the unit
  line itself is wrong. Every refusal comes before any warning;
- :class:`~clearance_pin.errors.SuspectValueWarning` otherwise: one odd value in a file that
  states its unit may be meant, and a value too small (a point near its frame, a slide near its
  zero, a very fine play or tolerance) breaks nothing.

Plays too large for their part and tolerances too wide for their size, when the warnings of
:mod:`~clearance_pin.model.plausibility` name them already, are not warned twice; nor a prismatic
``q`` beyond its URDF limits. The message names the element, the attribute, the value, the ratio
and its reference, the unit that would make the value normal, and what the file says of its unit:
``<joint name='shoulder_pan'>: radial_clearance 10 m is 73.6x the part it joins (0.13585 m; up to
0.01 is normal); was it written in um? (the file has no unit line: its lengths are read in
metres)``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Literal

from ..errors import ModelError, SuspectValueWarning
from .iso286 import ToleranceInputError, tolerance_m
from .plausibility import CLEARANCE_FRACTION, TOLERANCE_FRACTION  # what it warns already
from .reference_sizes import ROUND_OFF, Geometry
from .xml_values import UNITS

Kind = Literal["play", "size", "point", "position", "tolerance"]

OUT_OF_PROPORTION = 10.0  # outside the normal band by this factor: flagged
CERTAIN = 1000.0  # outside it by this factor: no design explains it, refused
AGREEING_SIZES = 2  # journal or block lengths all wrong by one unit: the unit line is wrong
# a play beyond this fraction of its part (and of its own journal) is no fit: ISO 286 fits give
# 1e-4 .. 5e-3 of the journal, a loose machine 1e-2; every play of a file beyond it: wrong unit
IMPLAUSIBLE_PLAY = 2e-2
# a part (a link: the distance between its joint centres and frames) larger than this [m] is
# warned of, and refused when the block's journals are all too small for their parts by a unit
# step: the model file's lengths are in that unit (a URDF exported in mm: a UR5's upper arm is
# 425 m). Cranes' booms aside, machines' parts are shorter; a long chain of short links is not
# judged by its length.
LARGE_PART = 20.0
MODEL_EXPONENTS = (-3,)  # the units a model file is exported in by mistake (mm)
FINEST_GRADE = "IT1"  # the finest ISO 286 grade of a machined part (IT01, IT0: gauge blocks)

# normal band (low, high) of the ratio of each kind of length to its reference (0, inf: none)
BANDS: dict[str, tuple[float, float]] = {
    "play": (0.0, 1e-2),  # a finer play breaks nothing (negligible_play.py rules on those)
    "play/length": (1e-4, 1e-2),
    "size": (1e-2, 3.0),
    "point": (1e-2, 1.0),
    "position": (1e-2, 1.0),
    "tolerance": (0.0, 2.0 * TOLERANCE_FRACTION / OUT_OF_PROPORTION),
    "tolerance/IT1": (1.0, math.inf),
}
UNIT_NAMES = {0: "m", -3: "mm", -6: "um"}


class ModelScaleError(ModelError):
    """The model file's own lengths, not the block's, are out of proportion (a URDF exported in
    mm): the reader of the model file names the file (``problem`` is the message)."""


@dataclass(frozen=True)
class Length:
    """One length of a block, as read [m], and what it belongs to.

    Attributes:
        label: the element as messages name it (``<joint name='elbow'>``, ``[joints.elbow]``).
        attribute: the attribute or key (``radial_clearance``, ``point``).
        value: the length [m] (a point's distance from its frame; half a diametral clearance;
            a dimension's full tolerance T).
        kind: ``"play"``, ``"size"`` (journal or block), ``"point"``, ``"position"`` (nominal
            value of a prismatic joint) or ``"tolerance"`` (a length dimension's tolerance).
        bodies: the Pinocchio joints (bodies) the value belongs to.
        own_length: a play's journal or block length [m] in the same element, else 0.
        reference: a tolerance's nominal size or a position's largest limit (of
            ``|lower|``, ``|upper|``) [m], else 0.
        written: the attribute's own value [m] when it differs from ``value`` (a diametral
            clearance, a half tolerance), for the message.
    """

    label: str
    attribute: str
    value: float
    kind: Kind
    bodies: tuple[int, ...] = ()
    own_length: float = 0.0
    reference: float = 0.0
    written: float = math.nan


def _out_by(ratio: float, band: tuple[float, float]) -> float:
    """By what factor a ratio lies outside a band (1 inside; a lower bound 0 is no bound)."""
    low, high = band
    if ratio > high:
        return ratio / high
    if low > 0.0 and ratio < low:
        return math.inf if ratio == 0.0 else low / ratio
    return 1.0


def _likely_unit(ratio: float, band: tuple[float, float], exponent: int) -> str | None:
    """The unit in which the value, written in it, would lie inside its band (nearest first)."""
    best = None
    for other, name in UNIT_NAMES.items():
        if other == exponent:
            continue
        rescaled = ratio * 10.0 ** (other - exponent)
        out = _out_by(rescaled, band)
        if out < OUT_OF_PROPORTION and (best is None or out < best[0]):
            best = (out, name)
    return None if best is None else best[1]


@dataclass(frozen=True)
class _Finding:
    length: Length
    ratio: float  # value / reference
    reference: float  # [m]
    basis: str  # what the reference is, in the message
    band: tuple[float, float]
    out: float  # by what factor the ratio is outside the band
    part: float  # the geometric size of the part [m] (0 when unknown)

    @property
    def too_large(self) -> bool:
        return self.ratio > self.band[1]

    @property
    def refused(self) -> bool:
        """Out by CERTAIN: a too large value, or a journal or block too small to be one (a
        too small play, point, position or tolerance may be meant: it is only warned)."""
        return self.out >= CERTAIN and (self.too_large or self.length.kind == "size")


def _references(length: Length, geometry: Geometry) -> list[tuple[float, str, str, float]]:
    """(reference [m], what it is, band name, part size [m]) against which a length is judged."""
    part, basis = geometry.part(length.bodies)
    known = part if basis == "the part it joins" else 0.0
    extent = (geometry.extent, "the mechanism's extent")
    if length.kind == "play":
        found = [(part, basis, "play", known)]
        # its journal is a reference only when it is in proportion itself (else it is named)
        own = length.own_length
        if own > 0.0 and (part <= 0.0 or _out_by(own / part, BANDS["size"]) < OUT_OF_PROPORTION):
            found.append((own, "its own length", "play/length", known))
        return found
    if length.kind == "size":
        return [(part, basis, "size", known)]
    if length.kind == "point":
        if length.value < ROUND_OFF * geometry.extent:  # round-off of a point at the origin
            return []
        return [(*extent, "point", known)]
    if length.kind == "position":
        if length.reference > 0.0:
            return [(length.reference, "its largest URDF limit", "position", known)]
        return [(*extent, "position", known)]
    if length.reference <= 0.0:  # an offset: judged against the extent, from above only
        return [(*extent, "tolerance", known)]
    found = [(length.reference, "its nominal size", "tolerance", known)]
    try:
        finest = tolerance_m(FINEST_GRADE, length.reference)
    except ToleranceInputError:  # beyond 500 mm: ISO 286 has no grade
        return found
    found.append((finest, f"ISO 286 {FINEST_GRADE} at its nominal size", "tolerance/IT1", known))
    return found


def _findings(length: Length, geometry: Geometry) -> list[_Finding]:
    """What is out of proportion about one length (empty when it is in proportion)."""
    if length.value == 0.0:
        return []
    found = []
    for reference, basis, band_name, part in _references(length, geometry):
        if reference <= 0.0:
            continue
        band = BANDS[band_name]
        ratio = length.value / reference
        out = _out_by(ratio, band)
        if out >= OUT_OF_PROPORTION:
            found.append(_Finding(length, ratio, reference, basis, band, out, part))
    return found


def _warned_elsewhere(finding: _Finding) -> bool:
    """A too large play or tolerance that plausibility's warning names already."""
    length = finding.length
    if not finding.too_large or finding.refused:
        return False
    if length.kind == "play":
        size = max(finding.part, length.own_length)
        return length.value > CLEARANCE_FRACTION * size > 0.0
    if length.kind == "position":  # beyond its limits: plausibility names it
        return length.reference > 0.0
    if length.kind == "tolerance":  # an offset's is judged against the length scale there
        nominal = length.reference
        return nominal <= 0.0 or 0.5 * length.value > TOLERANCE_FRACTION * nominal
    return False


def _misdeclared(
    lengths: list[Length], findings: list[_Finding], exponent: int
) -> tuple[_Finding, str] | None:
    """(the first finding, the unit meant) when the block's unit itself is wrong: it has at
    least :data:`AGREEING_SIZES` journal or block lengths, each out of proportion with its part,
    all pointing to one same other unit. One length wrong alone may be a typo in a unit the
    block means; every one of them wrong by one unit factor is the unit line."""
    sizes = [length for length in lengths if length.kind == "size"]
    if len(sizes) < AGREEING_SIZES:
        return None
    judged = {id(f.length): f for f in findings if f.length.kind == "size"}
    if any(id(length) not in judged for length in sizes):
        return None
    units = {_likely_unit(f.ratio, f.band, exponent) for f in judged.values()}
    if len(units) != 1 or None in units:
        return None
    return judged[id(sizes[0])], str(units.pop())


def _play_reference(length: Length, geometry: Geometry) -> float:
    """The size [m] a play is judged against: its own journal or block length when that is in
    proportion with its part (a play is a fraction of its fit), else its part."""
    part, _ = geometry.part(length.bodies)
    own = length.own_length
    if own > 0.0 and (part <= 0.0 or _out_by(own / part, BANDS["size"]) < OUT_OF_PROPORTION):
        return own
    return part


def _implausible_plays(
    lengths: list[Length], geometry: Geometry, exponent: int
) -> tuple[Length, list[float], str | None] | None:
    """(the first play, every play's ratio to its reference, the unit meant) when the block has
    at least two plays and every one is beyond :data:`IMPLAUSIBLE_PLAY` of its journal (of its
    part without one, :func:`_play_reference`): one play that large may be meant (a loose
    guide), all of them are a unit (a file stating ``unit = "mm"`` with its plays typed in um).
    The unit meant: the nearest smaller unit in which every play is within the normal band."""
    plays = [length for length in lengths if length.kind == "play" and length.value > 0.0]
    if len(plays) < AGREEING_SIZES:
        return None
    ratios = []
    for play in plays:
        reference = _play_reference(play, geometry)
        if reference <= 0.0:
            return None
        ratios.append(play.value / reference)
    if min(ratios) <= IMPLAUSIBLE_PLAY:
        return None
    meant = None
    for other, name in sorted(UNIT_NAMES.items(), reverse=True):
        if other < exponent and max(ratios) * 10.0 ** (other - exponent) <= BANDS["play"][1]:
            meant = name
            break
    return plays[0], ratios, meant


def _model_in_other_unit(
    lengths: list[Length], findings: list[_Finding], geometry: Geometry
) -> tuple[_Finding, int] | None:
    """(the first finding, the exponent of the model's likely unit) when the model, not the
    block, is in another unit: its largest part is beyond :data:`LARGE_PART` and every
    journal and block length of the block is too small for its part (out of proportion) but
    normal with the model's lengths read in that unit."""
    if max(geometry.sizes, default=0.0) <= LARGE_PART:
        return None
    sizes = [length for length in lengths if length.kind == "size" and length.value > 0.0]
    judged = {id(f.length): f for f in findings if f.length.kind == "size" and not f.too_large}
    if not sizes or any(id(length) not in judged for length in sizes):
        return None
    for exponent in MODEL_EXPONENTS:
        scale = 10.0**-exponent  # the parts' sizes divided by it: the ratios multiplied
        if all(_out_by(f.ratio * scale, f.band) == 1.0 for f in judged.values()):
            return judged[id(sizes[0])], exponent
    return None


def warn_model_scale(source: str, element: str, geometry: Geometry, stacklevel: int) -> None:
    """SuspectValueWarning for a model whose largest part is beyond :data:`LARGE_PART`: its
    lengths are likely in mm (a URDF exported in mm, its clearance file in proportion with it,
    reads every length 1000x and warns of nothing else)."""
    largest = max(geometry.sizes, default=0.0)
    if LARGE_PART < largest < math.inf:  # an infinite size is refused as such, not warned
        warnings.warn(
            SuspectValueWarning(
                f"{source}: {element}: the model's largest part is {largest:.6g} m (between its "
                f"joint centres and frames; warned beyond {LARGE_PART:g} m); was it exported in "
                "mm? Its lengths are read in metres: a 0.4 m link written in mm is 400 m"
            ),
            stacklevel=stacklevel + 1,
        )


def unit_note(unit: str | None, kind: str) -> str:
    """What the block says of its unit, for the messages."""
    if kind == "dict":
        return "a dict of clearances is in metres"
    if unit is None:
        where = "file" if kind == "file" else "block"
        return f"the {where} has no unit line: its lengths are read in metres"
    return f'the {"file" if kind == "file" else "block"} states unit="{unit}"'


def _message(finding: _Finding, exponent: int, note: str) -> str:
    length = finding.length
    what = {
        "play": "",
        "size": "",
        "point": " (distance of the force point from its link frame)",
        "position": " (nominal value of a prismatic joint)",
        "tolerance": f" (full width T = {length.value:.6g} m)"
        if length.attribute != "tolerance"
        else "",
    }[length.kind]
    shown = length.written if math.isfinite(length.written) else length.value
    if not math.isfinite(finding.ratio):
        proportion = "beyond any multiple of"
    elif finding.ratio >= 1.0:
        proportion = f"{finding.ratio:.3g}x"
    else:
        proportion = f"{finding.ratio:.3g} of"
    low, high = finding.band
    if low == 0.0:
        normal = f"up to {high:g}"
    elif high == math.inf:
        normal = f"from {low:g}"
    else:
        normal = f"{low:g} .. {high:g}"
    unit = _likely_unit(finding.ratio, finding.band, exponent)
    hint = f"; was it written in {unit}?" if unit else ""
    return (
        f"{length.attribute} {shown:.6g} m{what} is {proportion} {finding.basis} "
        f"({finding.reference:.6g} m; {normal} is normal){hint} ({note})"
    )


def check_lengths(
    source: str,
    lengths: list[Length],
    geometry: Geometry,
    unit: str | None,
    kind: str,
    stacklevel: int = 2,
) -> None:
    """Refuse or warn every length out of proportion with the mechanism's geometry.

    Args:
        source: the block's file, named in messages.
        lengths: every length the block gave, in metres.
        geometry: the model's reference sizes.
        unit: the unit the block states (``"mm"``), None when it states none.
        kind: ``"file"`` (a clearance file), ``"model"`` (a block inside a URDF) or ``"dict"``.

    Raises:
        ModelError: the first length out of proportion by :data:`CERTAIN` or more (too large,
            or a journal or block too small), too large at all in a clearance file without a
            unit line, or the first journal of a block whose every journal and block length is
            out of proportion the same way (its unit line is wrong).
    """
    exponent = UNITS[unit] if unit is not None else 0
    note = unit_note(unit, kind)
    unstated = kind == "file" and unit is None
    findings = [finding for length in lengths for finding in _findings(length, geometry)]
    # the model's own unit first: it makes every length of the block look wrong
    model_unit = _model_in_other_unit(lengths, findings, geometry)
    if model_unit is not None:
        finding, model_exponent = model_unit
        raise ModelScaleError(
            source,
            "<robot>",
            f"the model's own lengths look {10.0**-model_exponent:g}x too large: its largest "
            f"part is {max(geometry.sizes):.6g} m (between its joint centres), and every journal "
            f"and block length of {source} is too small for its part the same way "
            f"({finding.length.label}: {finding.length.attribute} {finding.length.value:.6g} m "
            f"is {finding.ratio:.3g} of {finding.reference:.6g} m); was the model file exported in "
            f"{UNIT_NAMES[model_exponent]}? Its lengths are read in metres",
        )
    for finding in findings:  # refused before anything is warned
        if finding.refused or (unstated and finding.too_large):
            raise ModelError(source, finding.length.label, _message(finding, exponent, note))
    misdeclared = _misdeclared(lengths, findings, exponent)
    if misdeclared is not None:
        finding, unit_meant = misdeclared
        raise ModelError(
            source,
            finding.length.label,
            f"{_message(finding, exponent, note)}; every journal and block length of the "
            f"{'file' if kind == 'file' else 'block'} is out of proportion the same way: its "
            f"lengths are likely in {unit_meant}",
        )
    if kind == "file":
        implausible = _implausible_plays(lengths, geometry, exponent)
        if implausible is not None:
            first, ratios, plays_meant = implausible
            hint = f": its plays are likely in {plays_meant}" if plays_meant else ""
            raise ModelError(
                source,
                first.label,
                f"{first.attribute} {first.value:.6g} m: every play of the file is "
                f"{100 * min(ratios):.3g} .. {100 * max(ratios):.3g} % of its journal (of its "
                f"part without one); a play beyond {100 * IMPLAUSIBLE_PLAY:g} % is no fit "
                f"({note}){hint}",
            )
    seen: set[tuple[str, str]] = set()
    for finding in findings:
        key = (finding.length.label, finding.length.attribute)
        if key in seen or _warned_elsewhere(finding):
            continue
        seen.add(key)
        warnings.warn(
            SuspectValueWarning(
                f"{source}: {finding.length.label}: {_message(finding, exponent, note)}"
            ),
            stacklevel=stacklevel + 1,
        )


__all__ = [
    "BANDS",
    "CERTAIN",
    "OUT_OF_PROPORTION",
    "Length",
    "ModelScaleError",
    "check_lengths",
    "warn_model_scale",
]
