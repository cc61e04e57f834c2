"""The interactive IL debugger (``asictl debug``): breakpoints, steps and prints at the IL
line, on a simulation (it looks through ``asictl.observe``)."""
