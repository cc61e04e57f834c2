"""``asictl dap``: the Debug Adapter Protocol over the IL debugger (docs/editors.md).

A thin layer, as ``lsp/`` is over ``il/``: ``asictl.lsp.framing`` reads and writes the
protocol's frames (the language server's too), ``adapter`` answers its requests, and a
*target* does the debugging: the IL debugger on a simulation (``simulated``, for
``launch``) or on a live emulated board (``attached``, for ``attach``). ``variables``
turns what the program uses into the scopes an editor shows.
"""
