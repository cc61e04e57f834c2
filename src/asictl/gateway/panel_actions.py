"""The front panel over the live board's socket: what ``gateway panel``, ``gateway press``,
``status`` and the monitor ask of a served gateway.

The gateway attaches these to its live board (``LiveBoard.actions``), so they travel as the
emulated board's actions do, on the loop that owns the board: ``panel`` (the panel now),
``press`` (keys down now, up after their hold, in master time; the answer comes when the
keys are up, or at once with ``wait`` false, for the monitor, whose refreshes then show
the display change while the keys are held) and ``view`` (the emulated board's view with
the panel added, which ``asictl status`` reads). A press is carried out by the gateway as
a whole: a client that goes away while it waits does not leave a key held.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

from asictl.gateway.slave import GatewaySlave
from asictl.host.emulated.actions import ActionError, run_action

JSON = Any
#: How often a waiting press looks whether its keys are up (seconds of wall time).
POLL_S = 0.01


def panel_actions(
    slave: GatewaySlave, tcp: Callable[[], tuple[str, int] | None] = lambda: None
) -> dict[str, Callable[[dict[str, JSON]], Awaitable[JSON]]]:
    """``tcp``: where the gateway listens for Modbus TCP, if it does; ``panel`` says it, so
    that a status read through that address finds this panel (``served_panel``)."""
    panel = slave.panel

    async def view(args: dict[str, JSON]) -> JSON:
        return {**run_action(slave.board, "view", args), "panel": panel.view()}

    async def show(args: dict[str, JSON]) -> JSON:
        listening = tcp()
        return {**panel.view(), "modbus_tcp": None if listening is None else list(listening)}

    async def press(args: dict[str, JSON]) -> JSON:
        keys, hold_ms = args.get("keys"), args.get("hold_ms")
        if not isinstance(keys, list) or not isinstance(hold_ms, int | float):
            raise ActionError("a press needs 'keys' (mode, set) and 'hold_ms'")
        slave.sync()
        try:
            panel.press(keys, float(hold_ms))
        except ValueError as exc:
            raise ActionError(f"malformed press: {exc}") from None
        while args.get("wait", True) and panel.busy_until_ms is not None:
            await asyncio.sleep(POLL_S)
            slave.sync()
        return panel.view()

    return {"view": view, "panel": show, "press": press}
