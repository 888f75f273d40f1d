r"""The family contract: a family is a subclass of :class:`Family`, and each of its capabilities a
:class:`Capability` among its bases.

A subclass states what the registry needs before anything heavy is imported as class keywords (its name, one
line of description, its targets' names in order) and implements :meth:`Family.targets` and
:meth:`Family.forms`, which import them.  A capability is a small abstract class with one method that returns
the service, imported inside the method, so that JAX, Mitsuba or matplotlib load only when a command calls
it.  basedpyright checks the contract where a family is instantiated (an unimplemented capability) and where
a method returns its service (a module or object that does not meet the service's type).
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    from fitlab.core._target import Target
    from fitlab.forms import Form

__all__ = ["Family", "Capability"]


class Family(abc.ABC):
    """A BRDF family: ``class MyFamily(Family, name="my_family", description="...", target_names=("a", "b"))``.

    name: the family's name (a built-in family's folder's name).
    description: one line.
    target_names: its targets' names, in the order commands list them: what the registry knows of the family
        without importing its targets (``fitlab refit --target a`` imports no other family's targets).
    """

    name: ClassVar[str]
    description: ClassVar[str]
    target_names: ClassVar[tuple[str, ...]]

    def __init_subclass__(cls, *, name: str, description: str, target_names: tuple[str, ...], **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.name, cls.description, cls.target_names = name, description, tuple(target_names)

    @abc.abstractmethod
    def targets(self) -> Sequence[Target]:
        """Its targets (:class:`fitlab.core.Target`), named and ordered as :attr:`target_names`."""

    @abc.abstractmethod
    def forms(self) -> Sequence[Form]:
        """Its forms (:class:`fitlab.forms.Form`), each of one of its targets."""

    def __repr__(self) -> str:
        return f"<family {self.name}>"


class Capability(abc.ABC):
    """Something a family does beyond its targets and forms, for the generic command that uses it: one abstract
    method returning the service.  :func:`fitlab.core.offering` finds the families that have one without
    calling it."""

    #: what the capability is called in messages ("family X has no tables", "... has no Monte Carlo")
    noun: ClassVar[str]
