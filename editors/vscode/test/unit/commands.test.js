"use strict";
// The command lines and launch configurations of the extension, without VS Code.
const test = require("node:test");
const assert = require("node:assert/strict");
const path = require("path");

const commands = require("../../lib/commands");

function config(values) {
  return { get: (key, fallback) => (key in values ? values[key] : fallback) };
}

test("the settings give the command lines of the server, the adapter and a scenario run", () => {
  const s = commands.settings(config({ path: "/venv/bin/asictl", lib: ["blocks", 7] }));
  assert.deepEqual(s, { command: "/venv/bin/asictl", lib: ["blocks"] });
  assert.deepEqual(commands.serverCommand(s), { command: "/venv/bin/asictl", args: ["lsp", "--lib", "blocks"] });
  assert.deepEqual(commands.adapterCommand(s), { command: "/venv/bin/asictl", args: ["dap", "--lib", "blocks"] });
  assert.deepEqual(commands.scenarioCommand(s, "/w/a.scenario.toml").args,
    ["sim", "--scenario", "/w/a.scenario.toml", "--json", "--lib", "blocks"]);
  assert.deepEqual(commands.coverageCommand(s, ["/w/a.scenario.toml", "/w/b.scenario.toml"], "/t/c.info").args,
    ["test", "/w/a.scenario.toml", "/w/b.scenario.toml", "-j", "1", "--coverage", "/t/c.info",
      "--coverage-format", "lcov", "--lib", "blocks"]);
});

test("an empty asictl.path falls back to asictl on the PATH", () => {
  assert.equal(commands.settings(config({ path: "" })).command, "asictl");
  assert.deepEqual(commands.settings(config({})).lib, []);
});

test("F5 without a launch.json debugs the file in the editor", () => {
  const program = path.join("/w", "blink.asi");
  assert.deepEqual(commands.resolveLaunch({}, program).config,
    { type: "asictl", request: "launch", name: "Debug blink.asi", program });
  const scenario = path.join("/w", "blink.scenario.toml");
  assert.equal(commands.resolveLaunch({}, scenario).config.scenario, scenario);
  assert.match(commands.resolveLaunch({}, "/w/latch.fb").error, /main program/);
  assert.match(commands.resolveLaunch({}, "/w/notes.txt").error, /open an \.asi program/);
  assert.match(commands.resolveLaunch(undefined, undefined).error, /launch\.json/);
});

test("a launch.json configuration is kept, and one without a program is refused", () => {
  const attach = { type: "asictl", request: "attach", port: "300h" };
  assert.equal(commands.resolveLaunch(attach, "/w/x.asi").config, attach);
  assert.match(commands.resolveLaunch({ type: "asictl", request: "launch" }, "/w/x.asi").error,
    /needs "program"/);
});
