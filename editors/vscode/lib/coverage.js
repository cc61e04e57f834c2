// Coverage reports shown through VS Code's test coverage API. `asictl test --coverage
// FILE --coverage-format lcov` writes the report; `parseLcov` reads it and `fileCoverage`
// makes VS Code's FileCoverage of each file (the `vscode` module is passed in, so the
// conversion is unit-tested in Node with stand-ins for its classes).
"use strict";

/**
 * lcov's tracefile: one record per source file (SF) up to end_of_record, with line hits
 * (DA:line,hits) and branches (BRDA:line,block,branch,taken; "-" is a branch never
 * reached). Returns [{ file, lines: [{ line, hits }], branches: [{ line, block, branch, taken }] }].
 */
function parseLcov(text) {
  const records = [];
  let current = null;
  for (const raw of (text || "").split(/\r?\n/)) {
    const line = raw.trim();
    const colon = line.indexOf(":");
    const tag = colon < 0 ? line : line.slice(0, colon);
    const value = colon < 0 ? "" : line.slice(colon + 1);
    if (tag === "SF") {
      current = { file: value, lines: [], branches: [] };
      records.push(current);
    } else if (tag === "end_of_record") {
      current = null;
    } else if (current && tag === "DA") {
      const [number, hits] = value.split(",");
      if (isCount(number) && isCount(hits)) {
        current.lines.push({ line: Number(number), hits: Number(hits) });
      }
    } else if (current && tag === "BRDA") {
      const [number, block, branch, taken] = value.split(",");
      if (isCount(number) && (taken === "-" || isCount(taken))) {
        current.branches.push({ line: Number(number), block, branch, taken: taken === "-" ? 0 : Number(taken) });
      }
    }
  }
  return records;
}

function isCount(text) {
  return typeof text === "string" && /^\d+$/.test(text.trim());
}

/**
 * VS Code's FileCoverage of one record: a StatementCoverage per line (its hits), with
 * the line's branches as BranchCoverage. `uriOf(file)` resolves the report's path (lcov
 * paths are relative to the folder the tests ran in).
 */
function fileCoverage(vscode, record, uriOf) {
  const branchesAt = new Map();
  for (const b of record.branches) {
    const label = `branch ${b.branch}` + (b.block !== "0" ? ` of block ${b.block}` : "");
    const list = branchesAt.get(b.line) || [];
    list.push(new vscode.BranchCoverage(b.taken, undefined, label));
    branchesAt.set(b.line, list);
  }
  const details = record.lines.map((l) => new vscode.StatementCoverage(
    l.hits, new vscode.Position(l.line - 1, 0), branchesAt.get(l.line) || []));
  return vscode.FileCoverage.fromDetails(uriOf(record.file), details);
}

module.exports = { parseLcov, fileCoverage };
