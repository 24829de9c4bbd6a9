"""How commands find a recording's sensors: ``--sensors thigh,shank`` addresses sensors by
name, serial or body segment ("Upper Leg", "tibia"), with the side when one is given;
:func:`match_sensor` returns the one meant or says which there are."""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping

from .errors import InputError

#: Segment synonyms, so that ``--sensors thigh,shank`` finds sensors labelled "Upper Leg"
#: or "tibia". Keys and values are normalised (:func:`normalised_name`).
SEGMENT_SYNONYMS = {
    "thigh": "thigh", "upperleg": "thigh", "femur": "thigh",
    "shank": "shank", "lowerleg": "shank", "tibia": "shank", "shin": "shank",
    "foot": "foot", "calcaneus": "foot",
    # one sensor on the pelvis serves both hips: its name's side, if any, is not the hip's
    "pelvis": "pelvis", "sacrum": "pelvis", "lowerback": "pelvis", "hips": "pelvis",
    "hip": "pelvis",
}
_SIDES = {"left": "left", "l": "left", "right": "right", "r": "right"}


def normalised_name(text: str) -> str:
    """``text`` in lower case without spaces, tabs, underscores, hyphens or dots.

    Returns
    -------
    str
        The key names and serials are compared by.

    Examples
    --------
    >>> from imucal.sensor_names import normalised_name
    >>> normalised_name("Left Upper_Leg")
    'leftupperleg'
    """
    return "".join(ch for ch in str(text).lower() if ch not in " _-.\t")


def segment_of(text: str) -> tuple[str | None, str | None]:
    """The side and body segment a sensor name denotes.

    Returns
    -------
    side : str or None
        "left" or "right" (from a word "left"/"l"/"right"/"r", or a leading "left"/
        "right" written as one word with the segment); None when the name gives none.
    segment : str or None
        "thigh", "shank", "foot" or "pelvis" (:data:`SEGMENT_SYNONYMS`); None when the
        name, without its side, is no known segment.

    Examples
    --------
    >>> from imucal.sensor_names import segment_of
    >>> segment_of("L Upper Leg"), segment_of("rightTibia"), segment_of("Opal 1234")
    (('left', 'thigh'), ('right', 'shank'), (None, None))
    """
    words = [w for w in re.split(r"[\s_\-.]+", str(text).lower()) if w]
    side = next((_SIDES[w] for w in words if w in _SIDES), None)
    rest = "".join(w for w in words if w not in _SIDES)
    for prefix in ("left", "right"):  # "leftthigh" written as one word
        if side is None and rest.startswith(prefix) and rest[len(prefix):] in SEGMENT_SYNONYMS:
            side, rest = prefix, rest[len(prefix):]
    return side, SEGMENT_SYNONYMS.get(rest)


def match_sensor(name: str, names: list[str], info: Mapping[str, Mapping] | None = None,
                 source: str = "<memory>") -> str:
    """The one sensor in ``names`` that ``name`` addresses.

    Tried in turn: the exact name; the name or the serial (``info[n]["serial"]``)
    ignoring case, spaces, underscores and hyphens; the body segment (thigh = upper leg =
    femur, shank = lower leg = tibia, foot = calcaneus, pelvis = sacrum = lower back = hip)
    with the side when one is given. ``info`` is :attr:`Recording.sensor_info`;
    ``source`` names the file in messages.

    Returns
    -------
    str
        The matching entry of ``names``.

    Raises
    ------
    InputError
        No sensor matches (listing the sensors there are, with serials, and a "did you
        mean" hint), or several sensors are the segment asked for.

    Examples
    --------
    >>> from imucal.sensor_names import match_sensor
    >>> match_sensor("left_thigh", ["Left Upper Leg", "Left Lower Leg"])
    'Left Upper Leg'
    >>> match_sensor("00B4", ["thigh"], {"thigh": {"serial": "00b4"}})
    'thigh'
    """
    info = info or {}
    if name in names:
        return name
    key = normalised_name(name)
    for how in ("name", "serial"):
        hits = [n for n in names if key and normalised_name(n if how == "name" else
                                                info.get(n, {}).get("serial") or "") == key]
        if len(hits) == 1:
            return hits[0]
    side, segment = segment_of(name)
    if segment is not None:
        hits = [n for n in names if segment_of(n)[1] == segment
                and (side is None or segment_of(n)[0] in (side, None))]
        if side is not None and len(hits) > 1:
            hits = [n for n in hits if segment_of(n)[0] == side]
        if len(hits) == 1:
            return hits[0]
        if len(hits) > 1:
            raise InputError(
                f"{source}: sensor '{name}' is ambiguous: {', '.join(map(repr, hits[:-1]))} "
                f"and {hits[-1]!r} each name a {segment}; name one of them (or give the "
                f"side, e.g. left_{segment})"
            )
    keys = {normalised_name(n): n for n in names}
    keys.update({normalised_name(v["serial"]): n for n, v in info.items() if v.get("serial")})
    close = difflib.get_close_matches(key, list(keys), n=1, cutoff=0.6)
    hint = f" (did you mean '{keys[close[0]]}'?)" if close else ""
    serials = [f"{n} ({info[n]['serial']})" if info.get(n, {}).get("serial")
               and info[n]["serial"] != n else n for n in names]
    raise InputError(
        f"{source}: no sensor '{name}'{hint}; sensors in this file: "
        f"{', '.join(serials) or 'none'}"
    )
