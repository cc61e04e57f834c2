"use strict";
// What a scenario run and a debug session say, as the Testing view shows it.
const test = require("node:test");
const assert = require("node:assert/strict");

const scenarios = require("../../lib/scenarios");

// `asictl sim --scenario blink.scenario.toml --json` (as sim/session.py's as_json writes it)
const FAILED = JSON.stringify({
  scenario: "blink.scenario.toml", passed: false, checked: 3,
  failures: [{ line: 12, at_ms: 250, operand: "Q 2.0", expected: 1, got: 0 }],
  stops: [{ at_ms: 300, reason: "program cycle time-out", where: "blink.asi:9" }],
  notes: [], end_ms: 400, wall_s: 0.1,
});

test("a passing run passes", () => {
  const passed = JSON.stringify({ scenario: "a.scenario.toml", passed: true, checked: 1, failures: [], stops: [] });
  assert.deepEqual(scenarios.outcome(passed, "", 0), { status: "passed", messages: [] });
});

test("failures are messages at their scenario lines, stops are messages too", () => {
  const result = scenarios.outcome(FAILED, "", 1);
  assert.equal(result.status, "failed");
  assert.deepEqual(result.messages[0], { text: "at 250 ms: Q 2.0 expected 1, got 0", file: "blink.scenario.toml", line: 12 });
  assert.equal(result.messages[1].text, "at 300 ms: program stopped: blink.asi:9: program cycle time-out");
});

test("an invalid scenario is an error at the diagnostics' lines", () => {
  const stderr = "x.scenario.toml:4:7: error: unknown operand 'Q 99.0' [E401]\n    set = ...\n";
  const result = scenarios.outcome("", stderr, 2);
  assert.equal(result.status, "errored");
  assert.deepEqual(result.messages, [{ text: "unknown operand 'Q 99.0' [E401]", file: "x.scenario.toml", line: 4 }]);
  assert.equal(scenarios.outcome("not json", "", 0).status, "errored");
  assert.match(scenarios.outcome("", "", 3).messages[0].text, /status 3/);
});

test("a debug session's console gives the same messages", () => {
  const console = "scenario /w/blink.scenario.toml\n"
    + "/w/blink.scenario.toml:12: at 250 ms: Q 2.0 expected 1, got 0\n"
    + "at 300 ms: program stopped: blink.asi:9: program cycle time-out\n"
    + "end of the simulation at 400 ms (3 expectations checked, 1 failed)\n";
  assert.deepEqual(scenarios.consoleMessages(console), [
    { text: "at 250 ms: Q 2.0 expected 1, got 0", file: "/w/blink.scenario.toml", line: 12 },
    { text: "at 300 ms: program stopped: blink.asi:9: program cycle time-out" },
  ]);
});
