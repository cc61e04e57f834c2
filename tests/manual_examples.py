"""The example programs of the programming manual (chapter 3), as reconstructed sources.

The manual's text extraction scrambled some tables; these are the reconstructions that
docs/language.md describes (one instruction per line, I2 where the extraction reads
"12", the underscore of MEAN_VALUE restored). Every layer's tests use them: the reader
asserts their AST, the checks find them clean, the compiler runs them.
"""

from __future__ import annotations

EXAMPLES: dict[str, str] = {
    "options": (  # 3.1
        "[Options]\n"
        "ignore_config_errors: yes\n"
        "auto_start:           no\n"
    ),
    "setup": (  # 3.2
        "[Setup]\n"
        "; slave: IO,   ID, Power-up Parameter\n"
        "  16:    iiio, 1,  Eh\n"
        "  3:     Bh,   0\n"
    ),
    "declaration": (  # 3.3, one declaration per line
        "[DECL]\n"
        "Reading     BYTE 5\n"
        "T134        TIMER\n"
        "C27         COUNTER\n"
        "MEAN_VALUE  FB MEAN.FB\n"
    ),
    "or_and_not": (  # 3.4.1
        "[Program]\n"
        "    O   I 4.0\n"
        "    O   I 5.0\n"
        "    AN  F 42.7\n"
        "    =   Q 17.3\n"
        "    ***\n"
    ),
    "subtraction": (  # 3.4.2
        "[Program]\n"
        "    L   FY 1\n"
        "    L   FY 2\n"
        "    -   F\n"
        "    T   FY 3\n"
        "    ***\n"
    ),
    "blink": (  # 3.4.2
        "[Program]\n"
        "        A   T 0      ;timer 0 still running\n"
        "        JC  = end    ;skip following lines\n"
        "        N\n"
        "        L   KT 500   ;timer 0 no longer running:\n"
        "        S   T 0      ;restart timer 0 with 500 ms\n"
        "        ***\n"
        "        AN  Q 31.0   ;invert output Q 31.0\n"
        "        =   Q 31.0\n"
        "end:    BE\n"
    ),
    "param_edges": (  # 3.4.6
        "[Program]\n"
        "    A   I  12.0     ;rising edge\n"
        "    AN  I2 12.0\n"
        "    L   KP 13.3     ;parameter value \"3\"\n"
        "    PARAM\n"
        "    ***\n"
        "\n"
        "    A   I2 12.0     ;falling edge\n"
        "    AN  I  12.0\n"
        "    L   KP 13.12    ;parameter value \"12\"\n"
        "    PARAM\n"
        "    ***\n"
    ),
    "gating": (  # 3.5
        "[Gating]\n"
        "Q 17.3 = I 4.0 or I 5.0 and not F 42.7\n"
        "Q 17.2 = I 5.0\n"
    ),
    "set_pp": (  # 3.8.2
        "[Program]\n"
        "    L   KB 17        ;load slave address\n"
        "    T   PSeg 0       ;write parameter passing segment\n"
        "\n"
        "    L   KB 0Ah       ;load power-up parameter\n"
        "    T   PSeg 1       ;write parameter passing segment\n"
        "\n"
        "    JU  FB SetPP     ;call firmware function block SetPP\n"
    ),
}
