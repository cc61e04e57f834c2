"""z3 terms as Python functions: a cycle's terms evaluated on concrete values fast enough
to run thousands of cycles (``z3.substitute`` and ``simplify`` take milliseconds a cycle).

Each term is translated once, node by node, into Python arithmetic with the bit-vector
semantics of its z3 operator; an operator not listed here is an error, never a guess.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import z3

from asictl.prove.symbolic import Cycle, Key, width

_INFIX = {
    z3.Z3_OP_BADD: "+", z3.Z3_OP_BSUB: "-", z3.Z3_OP_BMUL: "*",
    z3.Z3_OP_BAND: "&", z3.Z3_OP_BOR: "|", z3.Z3_OP_BXOR: "^",
}
_COMPARE = {
    z3.Z3_OP_ULEQ: "<=", z3.Z3_OP_UGEQ: ">=", z3.Z3_OP_ULT: "<", z3.Z3_OP_UGT: ">",
    z3.Z3_OP_EQ: "==", z3.Z3_OP_DISTINCT: "!=",
}


def compile_terms(terms: list[z3.ExprRef]) -> Callable[[Mapping[str, int]], list[int]]:
    """A function from variable name -> value to the values of ``terms`` (Bools as 0/1)."""
    lines: list[str] = []
    names: dict[int, str] = {}

    def visit(term: z3.ExprRef) -> str:
        ident = term.get_id()
        if ident in names:
            return names[ident]
        if z3.is_bv_value(term):
            return str(term.as_long())
        if z3.is_true(term):
            return "1"
        if z3.is_false(term):
            return "0"
        kind = term.decl().kind()
        if kind == z3.Z3_OP_UNINTERPRETED and term.num_args() == 0:
            code = f"env[{str(term.decl().name())!r}]"
        else:
            args = [visit(a) for a in term.children()]
            mask = (1 << term.size()) - 1 if z3.is_bv(term) else 1
            if kind in _INFIX:
                code = f"({(' ' + _INFIX[kind] + ' ').join(args)}) & {mask}"
            elif kind in _COMPARE:
                code = f"int({args[0]} {_COMPARE[kind]} {args[1]})"
            elif kind == z3.Z3_OP_BNEG:
                code = f"(-{args[0]}) & {mask}"
            elif kind == z3.Z3_OP_BNOT:
                code = f"(~{args[0]}) & {mask}"
            elif kind in (z3.Z3_OP_BUDIV, z3.Z3_OP_BUDIV_I):
                code = f"({args[0]} // {args[1]} if {args[1]} else {mask})"
            elif kind == z3.Z3_OP_BLSHR:
                code = f"({args[0]} >> {args[1]})"
            elif kind == z3.Z3_OP_BSHL:
                code = f"({args[0]} << {args[1]}) & {mask}"
            elif kind == z3.Z3_OP_EXTRACT:
                high, low = term.params()
                code = f"({args[0]} >> {low}) & {(1 << (high - low + 1)) - 1}"
            elif kind == z3.Z3_OP_CONCAT:
                code = args[0]
                for arg, child in zip(args[1:], term.children()[1:], strict=True):
                    code = f"(({code}) << {child.size()} | {arg})"
            elif kind == z3.Z3_OP_ZERO_EXT:
                code = args[0]
            elif kind == z3.Z3_OP_ITE:
                code = f"({args[1]} if {args[0]} else {args[2]})"
            elif kind == z3.Z3_OP_AND:
                code = f"int({' and '.join(args)})"
            elif kind == z3.Z3_OP_OR:
                code = f"int({' or '.join(args)})"
            elif kind == z3.Z3_OP_NOT:
                code = f"(1 - {args[0]})"
            elif kind == z3.Z3_OP_XOR:
                code = f"({args[0]} ^ {args[1]})"
            else:
                raise NotImplementedError(f"z3 operator {term.decl()} ({kind})")
        name = names[ident] = f"v{len(names)}"
        lines.append(f"    {name} = {code}")
        return name

    results = [visit(t) for t in terms]
    source = "def run(env):\n" + "\n".join(lines) + f"\n    return [{', '.join(results)}]\n"
    scope: dict[str, object] = {}
    exec(compile(source, "<z3 terms>", "exec"), scope)
    run = scope["run"]
    assert callable(run)
    return run  # type: ignore[no-any-return]


class Concrete:
    """A cycle run on concrete cells: ``step(inputs)`` is one program cycle."""

    def __init__(self, cycle: Cycle) -> None:
        self.cycle = cycle
        self.cells = cycle.cells
        self.run = compile_terms([cycle.post[c] for c in self.cells])
        self.state: dict[Key, int] = {}
        self.names = [(cell, var.decl().name()) for cell, var in cycle.pre.items()]

    def step(self, inputs: Mapping[str, int]) -> dict[Key, int]:
        env = {name: self.state.get(cell, 0) for cell, name in self.names}
        env.update({name: inputs.get(name, 0) for name in self.cycle.inputs})
        values = self.run(env)
        self.state = {c: v & ((1 << width(c)) - 1) for c, v in zip(self.cells, values,
                                                                   strict=True)}
        return self.state
