"""Regions: as much of a program as runs without jumping back, as one Python function.

A block (see :mod:`asictl.mcs51.emulator`) is straight-line code up to the next jump.
A PLC program's cycle is straight-line code with forward jumps (a ``JC`` over a network,
the branches of a timer or counter), so a block per jump means a dispatch per jump and
a reload of every register each time. A region takes everything reachable from its
entry by falling through and by forward jumps, up to ``MAX_REGION`` instructions: a
directed acyclic graph, laid out in address order, so a run through it only ever moves
down the function. Control flow within it is a local ``nxt`` tested at each basic
block; leaving it (a backward jump, a call or return, a computed jump, a register-bank
switch, a stop address, the size limit) returns the successor's cache key, as a block
does.

A backward jump to the region's own entry (a loop with a ``JNB`` or ``JC`` in its body:
a superblock) does not leave it: the function's body is a ``while`` loop, and that jump
starts the next pass when a whole pass still fits the budget the caller passes in
(``room_i`` instructions, ``room_c`` machine cycles), so the cached bytes and registers
stay in locals for every round instead of being stored and loaded around a dispatch.

What makes a region faster than its blocks, besides saving the dispatches:

* ACC, the carry and PSW stay in locals across the whole region.
* Every internal RAM byte the code addresses directly (registers, bit-addressable
  bytes, the compiler's direct cells) is a local ``rNN``: loaded on entry, stored on
  every exit. An instruction that reaches internal RAM through a computed address
  (``@R0``, the stack) first stores them and afterwards loads them again, and so does
  a call to a device on the XDATA bus.
* The carry's bit logic (``MOV C,bit``, ``ANL``/``ORL C,[/]bit``, ``CLR``/``SETB``/``CPL
  C``) is folded into one Python condition, evaluated where the carry is next needed:
  a network ``MOV C,a / ANL C,/b / ORL C,c / MOV d,C`` becomes
  ``if (a) and not (b) or (c): d |= m else: d &= ~m``, with the bits of bytes held in
  locals read and written through tables (``BIT_TABLES``). Only bit reads are folded,
  and the condition is evaluated before anything that could change what they read.
* Instructions and machine cycles are counted per basic block, both in one local (the
  cycles above bit 32: one addition a block), and handed back in ``iterations[0]`` and
  ``iterations[1]``. The emulator calls a region only when the sum over all its
  instructions fits the run's budget, and a pass round the loop starts only when the
  cycles so far leave room for that sum in both budgets (an instruction takes at least
  a cycle, so that is one comparison; with an instruction budget it may leave early,
  and the emulator calls it again with what is left), so budgets stay exact.
* ``nxt`` is tested only before a basic block that some path skips: the blocks every
  path goes through (where the branches meet again) run without a test.
"""

from __future__ import annotations

import heapq
import re
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field

from asictl.mcs51.isa import OPCODES
from asictl.mcs51.templates import FLUSH, RELOAD, Writer, register_locals, translation_key

#: Most instructions in one region: bounds the generated function's size (and the time
#: spent compiling it) for code that is one long fall-through.
MAX_REGION = 1024
#: Code that reaches internal RAM through computed addresses at many places (or calls
#: devices at many) would store and load the cached bytes at each: beyond this many such
#: lines a region works on memory directly.
MAX_SYNC_LINES = 2048

_DIRECT_IRAM = re.compile(r"iram\[(\d+)\]")
_COMPUTED_IRAM = re.compile(r"iram\[(?!\d+\])")
_CELL_WRITE = re.compile(r"^\s*r(\d+) [|&^]?= ", re.M)
#: What a line of generated code assigns to (a local, or the array it stores into).
_ASSIGNED = re.compile(r"^\s*(\w+)(?:\[[^\n]*?\])?\s*[|&^+-]?=(?!=)", re.M)
#: What a folded carry condition reads.
_READS = re.compile(r"\b(r\d+|a|c|sfr|pins)\b")
_CARRY = re.compile(r"\bc\b")

#: Bit n of a byte (a bool: a jump on True or False needs no truth test), the byte with
#: bit n set, with bit n clear, as tables the folded bit logic indexes (``BIT4[r37]``)
#: instead of computing ``r37 & 16``: an index into a tuple is one specialised
#: instruction, a bitwise operator a generic call. The translated code finds them
#: among its globals (``emulator._instantiate``).
BIT_TABLES: dict[str, tuple[int, ...]] = {
    **{f"BIT{n}": tuple(bool(v >> n & 1) for v in range(256)) for n in range(8)},
    **{f"SET{n}": tuple(v | 1 << n for v in range(256)) for n in range(8)},
    **{f"CLR{n}": tuple(v & (255 ^ 1 << n) for v in range(256)) for n in range(8)},
}
#: A folded bit test on a byte held in a local: ``r37 & 16``, ``a & 1``.
_LOCAL_BIT_TEST = re.compile(r"^(r\d+|a) & (\d+)$")

#: The carry instructions a region folds: opcode -> operation.
_FOLDS = {0xA2: "mov", 0x82: "and", 0xB0: "and not", 0x72: "or", 0xA0: "or not",
          0xC3: "clr", 0xD3: "setb", 0xB3: "cpl", 0x92: "store"}
#: Instructions that set the carry without reading it.
_CARRY_SETTERS = frozenset({0xA2, 0xC3, 0xD3})
_PSW, _ACC = 0xD0, 0xE0
#: A region counts a pass's instructions and machine cycles in one local: the cycles
#: above this bit, the instructions below (an instruction takes at least one cycle).
_CYCLES_SHIFT = 32
#: Most cycles one call goes round its loop for, so that the instructions never reach
#: the cycles' bits.
_MAX_CYCLES = 1 << 30
#: Longest chain of folded operations before the carry is computed anyway.
_MAX_FOLD = 12

Line = str | tuple[int, int | str]


@dataclass
class _Node:
    """One instruction of a region, as the templates wrote it."""

    address: int
    instructions: int
    cycles: int
    lines: list[Line]
    #: the address after it, if it can continue there
    fallthrough: int | None
    #: where it can jump to, when the target is a constant
    targets: list[int]
    #: ends a basic block: a jump, branch, call or return
    ends: bool
    conditional: bool
    bank_changes: bool
    #: reaches internal RAM at a computed address, so the cached bytes must be in memory
    computed_iram: bool
    #: a foldable carry instruction: its opcode and bit address (-1 without a bit)
    fold: tuple[int, int] | None = None
    predecessors: set[int] = field(default_factory=set)


@dataclass(frozen=True)
class Region:
    """A region's generated source and the most instructions and cycles one pass
    through it can take (the sum over all of them: each runs at most once a pass)."""

    source: str
    instructions: int
    cycles: int


def build_region(
    code: Sequence[int], entry: int, bank: int, stops: Collection[int]
) -> Region:
    """The region starting at ``entry`` in register bank base ``bank``."""
    nodes = _walk(code, entry, bank, stops)
    order = sorted(nodes)
    for address in order:
        node = nodes[address]
        if not node.bank_changes:
            for successor in _successors(node):
                if successor > address and successor in nodes:
                    nodes[successor].predecessors.add(address)
    blocks = _basic_blocks(nodes, order)
    source = _Emitter(nodes, blocks, bank, entry).source()
    return Region(
        source,
        sum(n.instructions for n in nodes.values()),
        sum(n.cycles for n in nodes.values()),
    )


def _walk(code: Sequence[int], entry: int, bank: int, stops: Collection[int]) -> dict[int, _Node]:
    """Every instruction reachable from ``entry`` by falling through and jumping forward."""
    nodes: dict[int, _Node] = {}
    pending = [entry]
    while pending and len(nodes) < MAX_REGION:
        address = heapq.heappop(pending)
        if address in nodes or (address != entry and address in stops):
            continue
        info = OPCODES[code[address]]
        if info is None:  # undefined: the emulator raises when it gets there
            continue
        writer = Writer(static=True, bank=bank)
        raw = bytes(code[(address + k) & 0xFFFF] for k in range(info.length))
        writer.instruction(info, address, raw)
        text = "\n".join(line for line in writer.lines if isinstance(line, str))
        node = _Node(
            address=address,
            instructions=1,
            cycles=info.cycles,
            lines=writer.lines,
            fallthrough=(address + info.length) & 0xFFFF if writer.falls_through else None,
            targets=[t for line in writer.lines if not isinstance(line, str)
                     for t in [line[1]] if isinstance(t, int)],
            ends=writer.ended,
            conditional=writer.ended and writer.falls_through,
            bank_changes=writer.bank_changes,
            computed_iram=bool(_COMPUTED_IRAM.search(text)),
            fold=_fold(code[address], raw),
        )
        nodes[address] = node
        if not node.bank_changes:
            for successor in _successors(node):
                if successor > address and successor not in nodes:
                    heapq.heappush(pending, successor)
    return nodes


def _fold(opcode: int, raw: bytes) -> tuple[int, int] | None:
    """The opcode and bit of a carry instruction the emitter may fold, else None."""
    if opcode not in _FOLDS:
        return None
    if len(raw) == 1:
        return opcode, -1
    bit = raw[1]
    byte = 0x20 + (bit >> 3) if bit < 0x80 else bit & 0xF8
    if byte == _PSW or (opcode == 0x92 and byte == _ACC):
        return None  # the carry itself and its neighbours: left to the templates
    return opcode, bit


def _successors(node: _Node) -> list[int]:
    """Where control can go after ``node`` (forward or not, in the region or not)."""
    successors = list(node.targets)
    if node.fallthrough is not None:
        successors.append(node.fallthrough)
    return successors


def _basic_blocks(nodes: dict[int, _Node], order: list[int]) -> list[list[int]]:
    """The nodes in address order, cut where control can arrive from elsewhere."""
    blocks: list[list[int]] = []
    previous: _Node | None = None
    for address in order:
        node = nodes[address]
        joins = (
            previous is not None
            and not previous.ends
            and not previous.bank_changes
            and previous.fallthrough == address
            and node.predecessors == {previous.address}
        )
        if joins:
            blocks[-1].append(address)
        else:
            blocks.append([address])
        previous = node
    return blocks


class _Emitter:
    """Writes a region's function from its basic blocks."""

    def __init__(
        self, nodes: dict[int, _Node], blocks: list[list[int]], bank: int, entry: int
    ) -> None:
        self.nodes = nodes
        self.blocks = blocks
        self.bank = bank
        self.entry = entry
        #: a pass's most instructions and cycles: the next pass starts if they fit
        self.pass_instructions = sum(n.instructions for n in nodes.values())
        self.pass_cycles = sum(n.cycles for n in nodes.values())
        cached = [n for n in nodes.values() if not n.computed_iram]
        text = "\n".join(
            line for n in cached for line in n.lines if isinstance(line, str)
        )
        self.cells = sorted({int(m) for m in _DIRECT_IRAM.findall(text)})
        self.written = sorted(
            {int(m) for m in _CELL_WRITE.findall(_DIRECT_IRAM.sub(r"r\1", text))}
        )
        syncs = len(nodes) - len(cached) + text.count(FLUSH)
        if syncs * len(self.cells) > MAX_SYNC_LINES:
            for node in nodes.values():
                node.computed_iram = False  # nothing cached: no instruction needs the memory
            self.cells, self.written = [], []
        self.cache = bool(self.cells)
        every = "\n".join(
            line for n in nodes.values() for line in n.lines if isinstance(line, str)
        )
        self.bank_changes = any(n.bank_changes for n in nodes.values())
        self.loads, self.stores = register_locals(every, self.bank_changes)
        self.out: list[str] = []
        #: the carry's folded condition not yet computed into ``c`` (None: ``c`` is current)
        self.carry: str | None = None
        self.folded = 0
        self.bits = Writer(static=True)  # writes bit tests
        self.certain = self._certain()

    def source(self) -> str:
        out = self.out
        out.append("    def region(room_i, room_c):")
        out += ["        " + load for load in self.loads]
        out += ["        " + load for load in self._load_cells()]
        if self._loops():
            # n <= k: a pass fits both budgets while the cycles so far leave room for it
            room = f"min(room_i - {self.pass_instructions}, room_c - {self.pass_cycles})"
            out.append(f"        last = min({room}, {_MAX_CYCLES}) + 1 << {_CYCLES_SHIFT}")
        out += ["        n = 0", "        while True:"]
        for block in self.blocks:
            first = self.nodes[block[0]]
            count = sum(self.nodes[a].instructions for a in block)
            cycles = sum(self.nodes[a].cycles for a in block)
            if first.address in self.certain:
                depth = 3
            else:
                depth = 4
                out.append(f"            if nxt == {first.address}:")
            out.append("    " * depth + f"n += {cycles << _CYCLES_SHIFT | count}")
            for index, address in enumerate(block):
                following = self.nodes[block[index + 1]] if index + 1 < len(block) else None
                self._instruction(self.nodes[address], depth, following)
        return "\n".join(out)

    def _loops(self) -> bool:
        """Does control go back to the entry (round the region's loop), by a jump or by
        running on into it (code that ends at FFFFh goes on at 0000h)?"""
        return any(self.entry in _successors(node) and not node.bank_changes
                   for node in self.nodes.values())

    def _inside(self, node: _Node, target: int | str) -> bool:
        """Does ``node`` go on at ``target`` further down the region (through ``nxt``)?"""
        return (isinstance(target, int) and target > node.address and target in self.nodes
                and not node.bank_changes)

    def _certain(self) -> set[int]:
        """The basic blocks control certainly reaches when it gets to their place in the
        function: every earlier path still in the region leads there, so ``nxt`` need
        not be tested (nor set, unless a test lies on the way)."""
        certain = set()
        pending = {self.entry}
        for block in self.blocks:
            start, last = block[0], self.nodes[block[-1]]
            if pending == {start}:
                certain.add(start)
            if start in pending:
                pending.discard(start)
                pending.update(t for t in _successors(last) if self._inside(last, t))
        return certain

    def _instruction(self, node: _Node, depth: int, following: _Node | None) -> None:
        """One instruction at ``depth``; the last of its basic block (no ``following``)
        passes control on.

        An instruction that reaches internal RAM through a computed address runs on
        memory: the cached bytes are stored before it and loaded again on every path
        that stays in the region.
        """
        last = following is None
        if node.fold is not None:
            self._fold(node.fold, depth, following)
            if last:
                self._compute_carry(depth)
                assert node.fallthrough is not None  # carry instructions fall through
                self._transfer(node, node.fallthrough, depth, False)
            return
        if self.carry is not None and (last or node.ends or self._disturbs(node)):
            self._compute_carry(depth)
        pad = "    " * (depth - 1)  # the templates indent their own lines by one level
        computed = node.computed_iram
        if computed:
            self._put(self._store_cells(), depth)
        for line in node.lines:
            if isinstance(line, tuple):
                line_depth, target = line
                self._transfer(node, target, depth + line_depth - 1, computed)
                continue
            stripped = line.strip()
            indent = pad + line[: len(line) - len(line.lstrip())]
            if stripped == FLUSH:
                if not computed:
                    self.out += [indent + line for line in self._store_cells()]
            elif stripped == RELOAD:
                if not computed:
                    self.out += [indent + line for line in self._load_cells()]
            else:
                cached = self.cache and not computed
                self.out.append(pad + (_DIRECT_IRAM.sub(r"r\1", line) if cached else line))
        if node.conditional:
            # The templates end a conditional jump with its "if": the jump is its body.
            assert node.fallthrough is not None
            self._put(["else:"], depth)
            self._transfer(node, node.fallthrough, depth + 1, computed)
        elif not node.ends:
            assert node.fallthrough is not None
            if computed:
                self._put(self._load_cells(), depth)
            if last:
                self._transfer(node, node.fallthrough, depth, False)

    def _code(self, node: _Node) -> str:
        """The node's lines as they run here (cached bytes as locals)."""
        text = "\n".join(line for line in node.lines if isinstance(line, str))
        return _DIRECT_IRAM.sub(r"r\1", text) if self.cache else text

    def _disturbs(self, node: _Node) -> bool:
        """Would ``node`` read the carry or change what its folded condition reads?"""
        if node.computed_iram:
            return True
        text = self._code(node)
        if FLUSH in text or _CARRY.search(text):
            return True
        assert self.carry is not None
        return not set(_ASSIGNED.findall(text)).isdisjoint(_READS.findall(self.carry))

    def _fold(self, fold: tuple[int, int], depth: int, following: _Node | None) -> None:
        opcode, bit = fold
        operation = _FOLDS[opcode]
        current = "c" if self.carry is None else self.carry
        if operation in ("clr", "setb"):
            self.carry = "0" if operation == "clr" else "1"
        elif operation == "cpl":
            self.carry = f"not ({current})"
        elif operation == "store":
            self._store_carry(bit, depth, following)
            return
        else:
            test = self.bits.bit_test(bit)
            if self.cache:
                test = _DIRECT_IRAM.sub(r"r\1", test)
            local = _LOCAL_BIT_TEST.match(test)
            if local:  # a table's 0 or 1 in place of the masked value: the same truth
                test = f"BIT{int(local[2]).bit_length() - 1}[{local[1]}]"
            self.carry = test if operation == "mov" else f"({current}) {operation} ({test})"
        self.folded += 1
        if self.folded > _MAX_FOLD:
            self._compute_carry(depth)

    def _store_carry(self, bit: int, depth: int, following: _Node | None) -> None:
        """MOV bit,C: the condition decides the bit; the carry is computed only if a later
        instruction of the basic block (or the next block) needs it."""
        byte = 0x20 + (bit >> 3) if bit < 0x80 else bit & 0xF8
        place = f"iram[{byte}]" if byte < 0x80 else f"sfr[{byte}]"
        if self.cache:
            place = _DIRECT_IRAM.sub(r"r\1", place)
        mask = 1 << (bit & 7)
        condition = self.carry
        needed = condition is not None and (
            following is None or following.fold is None or following.fold[0] not in _CARRY_SETTERS
        )
        n = bit & 7
        cached = place.startswith("r")  # a local: set and cleared through the tables
        self._put([f"if {condition or 'c'}:",
                   f"    {place} = SET{n}[{place}]" if cached else f"    {place} |= {mask}"],
                  depth)
        if needed:
            self._put(["    c = 1"], depth)
        self._put(["else:",
                   f"    {place} = CLR{n}[{place}]" if cached else f"    {place} &= {255 ^ mask}"],
                  depth)
        if needed:
            self._put(["    c = 0"], depth)
        self.carry, self.folded = None, 0

    def _compute_carry(self, depth: int) -> None:
        carry = self.carry
        if carry is not None:
            self._put([f"c = {carry}" if carry in ("0", "1") else f"c = 1 if {carry} else 0"],
                      depth)
            self.carry, self.folded = None, 0

    def _put(self, lines: list[str], depth: int) -> None:
        self.out += ["    " * depth + line for line in lines]

    def _store_cells(self) -> list[str]:
        return [f"iram[{cell}] = r{cell}" for cell in self.written]

    def _load_cells(self) -> list[str]:
        """The cached bytes into their locals: a run of consecutive addresses as one
        slice unpacked (``r8, r9, r10 = iram[8:11]``), cheaper than an index per byte."""
        runs: list[list[int]] = []
        for cell in self.cells:  # ascending
            if runs and runs[-1][-1] == cell - 1:
                runs[-1].append(cell)
            else:
                runs.append([cell])
        return [f"r{run[0]} = iram[{run[0]}]" if len(run) == 1 else
                f"{', '.join(f'r{c}' for c in run)} = iram[{run[0]}:{run[-1] + 1}]"
                for run in runs]

    def _transfer(self, node: _Node, target: int | str, depth: int, computed: bool) -> None:
        """Go on at ``target``: within the region (``nxt``), round its loop when the
        target is the entry and another pass fits the budget, or leave it with
        everything stored. ``computed``: the cached bytes are in memory now, not in the
        locals."""
        reload = self._load_cells() if computed else []
        if isinstance(target, int) and self._inside(node, target):
            tested = (node.address < block[0] < target and block[0] not in self.certain
                      for block in self.blocks)
            if target in self.certain and not any(tested):
                self._put(reload or ["pass"], depth)
            else:
                self._put([*reload, f"nxt = {target}"], depth)
            return
        if target == self.entry and not node.bank_changes:
            self._put(["if n < last:", *("    " + line for line in [*reload, "continue"])],
                      depth)
        lines = [] if computed else self._store_cells()
        lines += self.stores
        lines += [f"iterations[0] = n & {(1 << _CYCLES_SHIFT) - 1}",
                  f"iterations[1] = n >> {_CYCLES_SHIFT}"]
        lines.append(f"return {translation_key(target, self.bank, node.bank_changes)}")
        self._put(lines, depth)
