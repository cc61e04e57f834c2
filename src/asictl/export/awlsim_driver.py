"""Runs exported AWL in awlsim, cycle by cycle, for ``asictl export --check``.

This file is run by the Python that has awlsim installed (its own venv), as a script:
it imports nothing of asictl. It reads one JSON request a line on standard input and
answers each with one JSON line:

* ``{"load": AWL, "symbols": CSV}``: parse and build the program (English mnemonics)
  with its symbol table (awlsim's CSV form, may be empty); ``{"ok": true}`` or
  ``{"error": text}``.
* ``{"run": [[clock_ms, inputs_hex, {flag: value}], ...], "read": [[area, offset,
  length], ...]}``: a cold start (every memory zero, OB 100), then one OB 1 per entry:
  SFC 64's clock set to ``clock_ms`` past the start, the host's flag writes applied,
  the input image set; after each cycle the named memory is read (area ``"Q"``,
  ``"M"`` or a DB number). ``{"cycles": [[hex, ...], ...]}`` or ``{"error": text}``.

awlsim's clock is virtual here: the CPU's time stamp is the clock of the request
(started 200 ms before the 31-bit millisecond wrap, so every run crosses it).
"""

import json
import sys
from typing import Any

# isort: off
# in this order: awlsim's compiler imports half-initialised core modules otherwise
from awlsim_loader.common import AwlSimError, Project, S7CPUConfig  # type: ignore[import-not-found]
from awlsim_loader.core import AwlSim, SymTabParser  # type: ignore[import-not-found]
from awlsim_loader.awlcompiler import AwlParser  # type: ignore[import-not-found]
# isort: on

_START_MS = 0x7FFFFFFF - 200


class Machine:
    def __init__(self, awl: str, symbols: str) -> None:
        project = Project.fromProjectOrRawAwlData(awl.encode("utf-8"))
        parser = AwlParser()
        parser.parseSource(project.getAwlSources()[0])
        self.sim = AwlSim()
        self.sim.reset()
        self.cpu = self.sim.getCPU()
        self.cpu.getConf().setConfiguredMnemonics(S7CPUConfig.MNEMONICS_EN)
        if symbols:
            self.sim.loadSymbolTable(SymTabParser.parseText(
                symbols, autodetectFormat=True, mnemonics=S7CPUConfig.MNEMONICS_EN))
        self.sim.load(parser.getParseTree())
        self.sim.build()
        self.clock_ms = 0
        self.cpu.updateTimestamp = self._time_stamp

    def _time_stamp(self) -> None:
        self.cpu.now = (_START_MS + self.clock_ms + 0.5) / 1000.0

    def _memory(self, area: str) -> Any:
        cpu = self.cpu
        if area == "Q":
            return cpu.outputs.getRawDataBytes()
        if area == "I":
            return cpu.inputs.getRawDataBytes()
        if area == "M":
            return cpu.flags.getRawDataBytes()
        return cpu.getDB(int(area)).structInstance.memory.getRawDataBytes()

    def run(self, cycles: list[list[Any]], read: list[list[Any]]) -> list[list[str]]:
        cpu = self.cpu
        for memory in (cpu.flags, cpu.inputs, cpu.outputs):
            raw = memory.getRawDataBytes()
            raw[:] = bytes(len(raw))
        for db in cpu.allDBs():
            if db.structInstance is None:  # DB 0, awlsim's own
                continue
            raw = db.structInstance.memory.getRawDataBytes()
            raw[:] = bytes(len(raw))
        self.clock_ms = 0
        self.sim.startup()
        out = []
        for clock_ms, inputs, writes in cycles:
            self.clock_ms = clock_ms
            flags = self._memory("M")
            for n, value in writes.items():
                flags[int(n)] = value
            data = bytes.fromhex(inputs)
            self._memory("I")[:len(data)] = data
            self.sim.runCycle()
            out.append([bytes(self._memory(a)[o:o + n]).hex() for a, o, n in read])
        return out


def main() -> None:
    machine: Machine | None = None
    for text in sys.stdin:
        request = json.loads(text)
        answer: dict[str, object]
        try:
            if "load" in request:
                machine = Machine(request["load"], request.get("symbols", ""))
                answer = {"ok": True}
            elif machine is None:
                answer = {"error": "no program loaded"}
            else:
                answer = {"cycles": machine.run(request["run"], request["read"])}
        except AwlSimError as exc:
            answer = {"error": exc.getReport()}
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
