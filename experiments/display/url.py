"""A display URL parsed once: :class:`DisplayURL`.

The registry (:func:`experiments.display.registry.parse_display_url`) picks the backend of a
URL's scheme and the backend checks the URL (:meth:`Display.parse_url`); what comes back is a
:class:`DisplayURL` the session, the plugin, ``thermocue check`` and the command line pass on
and open (:func:`~experiments.display.registry.open_display` takes one as it is, without
checking it again). :func:`url_options` is the one reader of a URL's query options.

>>> url_options("emulator://?clock=virtual&seed=5&clock=real")
{'clock': 'real', 'seed': '5'}
>>> url_options("/dev/ttyACM0")
{}
"""
from __future__ import annotations

from dataclasses import dataclass, field
from urllib.parse import parse_qs, urlsplit

__all__ = ["DisplayURL", "url_options"]


def url_options(url: str) -> dict:
    """A URL's query options, the last non-empty value of each (``{}`` for a path or no query)."""
    text = str(url)
    if "?" not in text:
        return {}
    return {k: v[-1] for k, v in parse_qs(urlsplit(text).query).items()}


@dataclass(frozen=True)
class DisplayURL:
    """A display URL its backend has checked.

    Attributes
    ----------
    text : str
        The URL as given (what logs and ``session.json`` store).
    scheme : str
        The backend's scheme (``serial`` for a device path or a pyserial URL).
    backend : type
        The :class:`~experiments.display.base.Display` subclass that opens it.
    options : tuple of (str, str)
        Its query options (:func:`url_options`), in order.
    """

    text: str
    scheme: str
    backend: type = field(compare=False, repr=False)
    options: tuple = ()

    def option(self, name: str, default=None):
        """The query option ``name`` (its last value), else ``default``."""
        return dict(self.options).get(name, default)

    @property
    def clock(self) -> str | None:
        """``"virtual"`` or ``"real"`` when the query names the session clock, else None."""
        value = self.option("clock")
        return value if value in ("virtual", "real") else None

    def __str__(self) -> str:
        return self.text
