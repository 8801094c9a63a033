"""What every request of ``labsim lsp`` shares: the server's state, its protocol, and its errors.

``LabsimServer`` is pygls's server with the checkers of each kind of file (``Checkers``; the
command line adds the grader's), the checks pending, and the last outline of each document that
composed; ``_Protocol`` answers a request it cannot read with an error; ``Refused`` is a request
declined with the reason an editor shows.
"""
from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote, urlparse

from pygls.exceptions import JsonRpcException
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol

from labsim.foundation.version import version
from labsim.runtime.lsp import language
from labsim.runtime.lsp.outline import Outline


class Refused(JsonRpcException):
    """A request the server understood and declines, with the reason the editor shows (the
    protocol's RequestFailed)."""

    CODE = -32803


class Protocol(LanguageServerProtocol):
    """pygls's protocol, answering a request whose parameters it cannot read (a negative line,
    a missing position) with an error rather than leaving the editor waiting."""

    def structure_message(self, data: dict[str, Any]) -> Any:
        try:
            return super().structure_message(data)
        except JsonRpcException as e:
            if isinstance(data, dict) and "id" in data and "method" in data:
                self._send_response(data["id"], error=e.to_response_error())
            raise


@dataclass
class Checkers:
    """The checker and the schema of each kind of file the server knows."""

    check: dict[str, language.Checker]
    schema: dict[str, Callable[[], dict[str, Any]]]


def default_checkers() -> Checkers:
    return Checkers({"behaviour": language.check_behaviour, "world": language.check_world},
                    {"behaviour": language.behaviour_keys, "world": language.world_keys})


class LabsimServer(LanguageServer):
    def __init__(self, checkers: Checkers) -> None:
        super().__init__("labsim", version(), protocol_cls=Protocol)
        self.checkers = checkers
        self.pending: dict[str, asyncio.Task[None]] = {}
        self.outlines: dict[str, Outline] = {}  # the last outline of each document that composed
        self.worker = ThreadPoolExecutor(1, thread_name_prefix="labsim-check")
        self.builtins = language.builtins()


def uri_path(uri: str) -> str:
    """The file a document URI names, or the URI itself for an unsaved buffer (untitled:)."""
    parsed = urlparse(uri)
    return unquote(parsed.path) if parsed.scheme == "file" else uri
