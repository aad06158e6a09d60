"""Transitional: the class priors now live in :mod:`usdworld.io.class_table`.

Layout code takes a :class:`~usdworld.io.class_table.ClassTable` passed in from the edge;
this module remains only until every caller does, and is then removed.
"""

from __future__ import annotations

from usdworld.io.class_table import YAW_MODES, ClassPrior, ClassTable, load_class_table

__all__ = ["YAW_MODES", "ClassPrior", "ClassTable", "class_priors", "prior_for"]


def class_priors() -> ClassTable:
    """All class priors by placed class name (the shipped table)."""
    return load_class_table()


def prior_for(class_name: str) -> ClassPrior:
    """The prior of one class; InputError naming the known classes otherwise."""
    return load_class_table()[class_name]
