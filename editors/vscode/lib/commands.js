// How the extension runs asictl: the command lines of the language server, the debug
// adapter and a scenario run, and the launch configuration F5 gets without a launch.json.
// No `vscode` here, so the unit tests run in plain Node (test/unit).
"use strict";

const path = require("path");

/** The settings the extension reads, with their defaults. */
function settings(config) {
  const lib = config.get("lib", []);
  return {
    command: config.get("path", "asictl") || "asictl",
    lib: Array.isArray(lib) ? lib.filter((folder) => typeof folder === "string") : [],
  };
}

function libArgs(lib) {
  const args = [];
  for (const folder of lib) {
    args.push("--lib", folder);
  }
  return args;
}

/** `asictl lsp --lib DIR ...` */
function serverCommand(s) {
  return { command: s.command, args: ["lsp", ...libArgs(s.lib)] };
}

/** `asictl dap --lib DIR ...` */
function adapterCommand(s) {
  return { command: s.command, args: ["dap", ...libArgs(s.lib)] };
}

/** `asictl sim --scenario FILE --json`: one scenario of the Testing view. */
function scenarioCommand(s, scenario) {
  return { command: s.command, args: ["sim", "--scenario", scenario, "--json", ...libArgs(s.lib)] };
}

/**
 * `asictl test FILE... -j 1 --coverage REPORT --coverage-format lcov`: the chosen
 * scenarios of a coverage run, their IL coverage written to REPORT.
 */
function coverageCommand(s, scenarioFiles, report) {
  return {
    command: s.command,
    args: ["test", ...scenarioFiles, "-j", "1", "--coverage", report, "--coverage-format", "lcov",
      ...libArgs(s.lib)],
  };
}

const IL_FILE = /\.(asi|fb)$/i;
const SCENARIO_FILE = /\.scenario\.toml$/i;

/**
 * The launch configuration to debug with: the one given, or (F5 without a launch.json)
 * one for the file in the editor. Returns { config } or { error }.
 */
function resolveLaunch(config, activeFile) {
  if (config && config.type && config.request) {
    if (config.request === "launch" && !config.program && !config.scenario) {
      return { error: "an asictl launch configuration needs \"program\" (an .asi file) or \"scenario\"" };
    }
    return { config };
  }
  if (activeFile && SCENARIO_FILE.test(activeFile)) {
    return { config: { type: "asictl", request: "launch", name: `Debug ${path.basename(activeFile)}`, scenario: activeFile } };
  }
  if (activeFile && /\.fb$/i.test(activeFile)) {
    return { error: "a function block runs in its main program: open the .asi file that calls it, or give \"program\" in launch.json" };
  }
  if (activeFile && IL_FILE.test(activeFile)) {
    return { config: { type: "asictl", request: "launch", name: `Debug ${path.basename(activeFile)}`, program: activeFile } };
  }
  return { error: "open an .asi program or a .scenario.toml file to debug it, or add an asictl configuration to launch.json" };
}

module.exports = {
  settings, serverCommand, adapterCommand, scenarioCommand, coverageCommand, resolveLaunch, SCENARIO_FILE,
};
