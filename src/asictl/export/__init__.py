"""Exports of a program for the PLC that replaces the master: S7 STL (AWL), IEC 61131-3
Structured Text and PLCopen XML, and the checks that they behave as the master does."""
