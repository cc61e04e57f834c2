"use strict";
// extension.js against a stand-in of the `vscode` module: what it registers, what it says
// when asictl cannot be found, and a scenario of the Testing view run for real when
// ASICTL_TEST_COMMAND names an asictl to run (the Python suite sets it).
const test = require("node:test");
const assert = require("node:assert/strict");
const fs = require("fs");
const Module = require("module");
const os = require("os");
const path = require("path");

function fakeVscode(settings) {
  const log = { errors: [], registered: {}, profiles: [], results: [], executables: [], coverage: [], output: [] };
  class Disposable { dispose() {} }
  class Uri {
    constructor(fsPath) { this.fsPath = fsPath; this.scheme = "file"; }
    static file(p) { return new Uri(p); }
    toString() { return `file://${this.fsPath}`; }
  }
  const items = new Map();
  const controller = {
    items: {
      get: (id) => items.get(id), add: (item) => items.set(item.id, item),
      delete: (id) => items.delete(id), replace: () => items.clear(),
      forEach: (f) => items.forEach((item) => f(item)),
    },
    createTestItem: (id, label, uri) => ({ id, label, uri }),
    createRunProfile: (label, kind, handler) => log.profiles.push({ label, kind, handler }),
    createTestRun: () => ({
      started() {}, skipped(item) { log.results.push(["skipped", item.label]); },
      passed(item) { log.results.push(["passed", item.label]); },
      failed(item, messages) { log.results.push(["failed", item.label, messages]); },
      errored(item, messages) { log.results.push(["errored", item.label, messages]); },
      addCoverage(file) { log.coverage.push(file); },
      appendOutput(text) { log.output.push(text); },
      end() {},
    }),
    dispose() {},
  };
  const vscode = {
    Uri, Disposable,
    Position: class { constructor(line, character) { this.line = line; this.character = character; } },
    Location: class { constructor(uri, position) { this.uri = uri; this.range = position; } },
    TestMessage: class { constructor(message) { this.message = message; } },
    BranchCoverage: class { constructor(executed, location, label) { Object.assign(this, { executed, location, label }); } },
    StatementCoverage: class { constructor(executed, location, branches) { Object.assign(this, { executed, location, branches }); } },
    FileCoverage: { fromDetails: (uri, details) => ({ uri, details }) },
    TestRunProfileKind: { Run: 1, Debug: 2, Coverage: 3 },
    DebugAdapterExecutable: class {
      constructor(command, args, options) { Object.assign(this, { command, args, options }); log.executables.push(this); }
    },
    workspace: {
      getConfiguration: () => ({ get: (key, fallback) => (key in settings ? settings[key] : fallback) }),
      onDidChangeConfiguration: () => new Disposable(),
      findFiles: async () => [],
      createFileSystemWatcher: () => ({ onDidCreate() {}, onDidDelete() {}, dispose() {} }),
      getWorkspaceFolder: () => undefined,
    },
    window: { showErrorMessage: async (message) => { log.errors.push(message); }, showInformationMessage: async () => {}, activeTextEditor: undefined },
    commands: { registerCommand: (name) => { log.registered[name] = true; return new Disposable(); }, executeCommand: async () => {} },
    debug: {
      registerDebugAdapterDescriptorFactory: (type, factory) => { log.registered.factory = factory; return new Disposable(); },
      registerDebugConfigurationProvider: (type, provider) => { log.registered.provider = provider; return new Disposable(); },
      registerDebugAdapterTrackerFactory: () => new Disposable(),
      activeDebugSession: undefined,
    },
    tests: { createTestController: () => controller },
  };
  return { vscode, log, controller };
}

function loadExtension(settings) {
  const fake = fakeVscode(settings);
  const clients = fake.log.clients = [];
  const load = Module._load;
  Module._load = function (request, parent, isMain) {
    if (request === "vscode") {
      return fake.vscode;
    }
    if (request === "vscode-languageclient/node") {
      return {
        TransportKind: { stdio: 0 },
        LanguageClient: class {
          constructor(id, name, server, options) { clients.push({ id, server, options }); }
          async start() { throw new Error("no server in this test"); }
          async stop() {}
        },
      };
    }
    return load.call(this, request, parent, isMain);
  };
  try {
    delete require.cache[require.resolve("../../extension")];
    return { extension: require("../../extension"), ...fake };
  } finally {
    Module._load = load;
  }
}

const context = { subscriptions: [] };

test("without asictl the extension says to set asictl.path, for the server and the debugger", async () => {
  const { extension, log } = loadExtension({ path: "/nonexistent/asictl" });
  await extension.activate(context);
  assert.ok(log.registered["asictl.stepCycle"]);
  assert.equal(log.profiles.map((p) => p.label).join(","), "Run,Debug,Run with Coverage");
  assert.deepEqual(log.profiles.map((p) => p.kind), [1, 2, 3]);
  assert.match(log.errors[0], /language server cannot start: '\/nonexistent\/asictl'.*asictl\.path/);
  const descriptor = log.registered.factory.createDebugAdapterDescriptor({ workspaceFolder: undefined });
  assert.equal(descriptor, undefined);
  assert.match(log.errors[1], /debug adapter cannot start.*asictl\.path/);
});

test("with asictl the debugger runs `asictl dap`, and F5 debugs the open program", async () => {
  const { extension, log, vscode } = loadExtension({ path: process.execPath, lib: ["blocks"] });
  await extension.activate(context);
  assert.match(log.errors[0], /language server failed to start.*no server in this test/);
  const [started] = log.clients;
  assert.deepEqual(started.server, { command: process.execPath, args: ["lsp", "--lib", "blocks"], transport: 0 });
  assert.deepEqual(started.options.documentSelector.map((s) => s.scheme), ["file", "untitled"]);
  const folder = { uri: vscode.Uri.file("/w") };
  const descriptor = log.registered.factory.createDebugAdapterDescriptor({ workspaceFolder: folder });
  assert.deepEqual([descriptor.command, descriptor.args, descriptor.options.cwd],
    [process.execPath, ["dap", "--lib", "blocks"], "/w"]);
  vscode.window.activeTextEditor = { document: { uri: vscode.Uri.file("/w/blink.asi") } };
  const config = log.registered.provider.resolveDebugConfiguration(folder, {});
  assert.deepEqual(config, { type: "asictl", request: "launch", name: "Debug blink.asi", program: "/w/blink.asi", cwd: "/w" });
});

const command = process.env.ASICTL_TEST_COMMAND;

test("a scenario of the Testing view runs, and its failure is at its line", { skip: !command && "ASICTL_TEST_COMMAND is not set (the Python suite sets it)" }, async () => {
  const folder = fs.mkdtempSync(path.join(os.tmpdir(), "asictl-scenario-"));
  fs.writeFileSync(path.join(folder, "lamp.asi"), "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n        A   I 1.0\n        =   Q 2.0\n");
  const good = path.join(folder, "lamp.scenario.toml");
  fs.writeFileSync(good, "[[step]]\nat_ms = 0\nset = { \"I 1.0\" = 1 }\n[[step]]\nat_ms = 20\nexpect = { \"Q 2.0\" = 1 }\n");
  const bad = path.join(folder, "dark.scenario.toml");
  fs.writeFileSync(bad, "program = \"lamp.asi\"\n[[step]]\nat_ms = 20\nexpect = { \"Q 2.0\" = 1 }\n");
  const { extension, log, vscode, controller } = loadExtension({ path: command });
  await extension.activate(context);
  for (const file of [good, bad]) {
    controller.items.add(controller.createTestItem(file, path.basename(file), vscode.Uri.file(file)));
  }
  const run = log.profiles.find((p) => p.label === "Run");
  await run.handler({ include: undefined, exclude: [] }, { isCancellationRequested: false, onCancellationRequested() {} });
  assert.deepEqual(log.results.map((r) => r.slice(0, 2)), [["passed", "lamp.scenario.toml"], ["failed", "dark.scenario.toml"]]);
  const [message] = log.results[1][2];
  assert.equal(message.message, "at 20 ms: Q 2.0 expected 1, got 0");
  assert.equal(message.location.uri.fsPath, bad);
  assert.equal(message.location.range.line, 3); // line 4 of the file, 0-based
});

test("a coverage run shows the lines and branches the scenarios reached", { skip: !command && "ASICTL_TEST_COMMAND is not set (the Python suite sets it)" }, async () => {
  const folder = fs.mkdtempSync(path.join(os.tmpdir(), "asictl-coverage-"));
  fs.writeFileSync(path.join(folder, "lamp.asi"),
    "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n        A   I 1.0\n        JC  = lit\n        BE\nlit:    =   Q 2.0\n");
  const scenario = path.join(folder, "lamp.scenario.toml");
  fs.writeFileSync(scenario, "[[step]]\nat_ms = 20\nexpect = { \"Q 2.0\" = 0 }\n");
  const { extension, log, vscode, controller } = loadExtension({ path: command });
  await extension.activate(context);
  controller.items.add(controller.createTestItem(scenario, "lamp.scenario.toml", vscode.Uri.file(scenario)));
  const profile = log.profiles.find((p) => p.label === "Run with Coverage");
  await profile.handler({ include: undefined, exclude: [] }, { isCancellationRequested: false, onCancellationRequested() {} });
  assert.deepEqual(log.results.map((r) => r.slice(0, 2)), [["passed", "lamp.scenario.toml"]]);
  assert.deepEqual(log.output, []);
  const [file] = log.coverage;
  assert.equal(file.uri.fsPath, path.join(folder, "lamp.asi"));
  // lines 5-8 (0-based 4-7): 'lit: = Q 2.0' never runs, the JC is never taken
  const hits = file.details.map((d) => [d.location.line, d.executed > 0]);
  assert.deepEqual(hits, [[4, true], [5, true], [6, true], [7, false]]);
  const jc = file.details[1].branches.map((b) => b.executed > 0);
  assert.deepEqual(jc, [false, true]);
});
