"""Placeholder: filled in by a later slice."""

from __future__ import annotations

NAME = "ximu3"


def sniff(path) -> bool:
    return False


def read(path, source=None):
    raise NotImplementedError
