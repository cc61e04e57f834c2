"use strict";
// An lcov report as VS Code's test coverage shows it, with stand-ins for VS Code's classes.
const test = require("node:test");
const assert = require("node:assert/strict");

const coverage = require("../../lib/coverage");

// hand-written, in lcov's tracefile format: two files, line hits, a branch never reached
const SAMPLE = `TN:
SF:demos/blink.asi
DA:12,5
DA:13,5
DA:14,0
BRDA:13,0,0,3
BRDA:13,0,1,-
LF:3
LH:2
end_of_record
SF:demos/latch.fb
DA:8,2
DA:x,1
end_of_record
DA:99,1
`;

class Position { constructor(line, character) { this.line = line; this.character = character; } }
class BranchCoverage { constructor(executed, location, label) { Object.assign(this, { executed, location, label }); } }
class StatementCoverage { constructor(executed, location, branches) { Object.assign(this, { executed, location, branches }); } }
const FileCoverage = { fromDetails: (uri, details) => ({ uri, details }) };
const vscode = { Position, BranchCoverage, StatementCoverage, FileCoverage };

test("lcov records: files, line hits and branches; malformed lines are left out", () => {
  const records = coverage.parseLcov(SAMPLE);
  assert.deepEqual(records.map((r) => r.file), ["demos/blink.asi", "demos/latch.fb"]);
  assert.deepEqual(records[0].lines, [{ line: 12, hits: 5 }, { line: 13, hits: 5 }, { line: 14, hits: 0 }]);
  assert.deepEqual(records[0].branches, [
    { line: 13, block: "0", branch: "0", taken: 3 },
    { line: 13, block: "0", branch: "1", taken: 0 },
  ]);
  assert.deepEqual(records[1].lines, [{ line: 8, hits: 2 }]); // DA:x and the DA after end_of_record
  assert.deepEqual(coverage.parseLcov(""), []);
});

test("a record becomes a FileCoverage of statements (0-based lines) with their branches", () => {
  const [blink] = coverage.parseLcov(SAMPLE);
  const file = coverage.fileCoverage(vscode, blink, (name) => `file:///w/${name}`);
  assert.equal(file.uri, "file:///w/demos/blink.asi");
  assert.deepEqual(file.details.map((d) => [d.location.line, d.executed, d.branches.length]),
    [[11, 5, 0], [12, 5, 2], [13, 0, 0]]);
  assert.deepEqual(file.details[1].branches.map((b) => [b.executed, b.label]), [[3, "branch 0"], [0, "branch 1"]]);
});
