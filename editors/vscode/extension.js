// The AS-i Control IL extension. The TextMate grammar (package.json) colours the code;
// this file wires asictl into VS Code: the language server (`asictl lsp`: diagnostics,
// hover, navigation, completion, formatting), the debugger (`asictl dap`: launch
// configurations, breakpoints, the "step one program cycle" button) and the scenarios
// in the Testing view (each *.scenario.toml a test, run, debugged and run with coverage
// from there).
// Plain JavaScript, so the extension needs no build step; the logic that needs no
// `vscode` is in lib/ and unit-tested in Node (test/unit).
"use strict";

const childProcess = require("child_process");
const fs = require("fs");
const os = require("os");
const path = require("path");
const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

const commands = require("./lib/commands");
const coverage = require("./lib/coverage");
const scenarios = require("./lib/scenarios");
const startup = require("./lib/startup");

let client;

const clientOptions = {
  documentSelector: [
    { scheme: "file", language: "asi" },
    { scheme: "untitled", language: "asi" },
  ],
};

function currentSettings() {
  return commands.settings(vscode.workspace.getConfiguration("asictl"));
}

/** Tell the user why asictl cannot start, with a button to the setting. */
async function explain(message) {
  const open = "Open the asictl.path setting";
  if (await vscode.window.showErrorMessage(message, open) === open) {
    await vscode.commands.executeCommand("workbench.action.openSettings", "asictl.path");
  }
}

// ---------------------------------------------------------------- the language server

async function startServer() {
  const s = currentSettings();
  if (!startup.findExecutable(s.command)) {
    explain(startup.notFound("the language server", s.command));
    return;
  }
  const { command, args } = commands.serverCommand(s);
  client = new LanguageClient("asictl", "asictl IL language server",
    { command, args, transport: TransportKind.stdio }, clientOptions);
  try {
    await client.start();
  } catch (error) {
    client = undefined;
    explain(startup.failed("the language server", s.command, error));
  }
}

async function stopServer() {
  if (client) {
    const running = client;
    client = undefined;
    await running.stop();
  }
}

// ---------------------------------------------------------------- the debugger

const adapterFactory = {
  createDebugAdapterDescriptor(session) {
    const s = currentSettings();
    if (!startup.findExecutable(s.command)) {
      explain(startup.notFound("the debug adapter", s.command));
      return undefined;
    }
    const { command, args } = commands.adapterCommand(s);
    const folder = session.workspaceFolder ? session.workspaceFolder.uri.fsPath : undefined;
    return new vscode.DebugAdapterExecutable(command, args, folder ? { cwd: folder } : {});
  },
};

const configurationProvider = {
  resolveDebugConfiguration(folder, config) {
    const editor = vscode.window.activeTextEditor;
    const active = editor && editor.document.uri.scheme === "file" ? editor.document.uri.fsPath : undefined;
    const resolved = commands.resolveLaunch(config, active);
    if (resolved.error) {
      vscode.window.showErrorMessage(`asictl: ${resolved.error}`);
      return undefined;
    }
    const result = { ...resolved.config };
    if (!result.cwd && folder) {
      result.cwd = folder.uri.fsPath;
    }
    return result;
  },
};

async function stepCycle() {
  const session = vscode.debug.activeDebugSession;
  if (!session || session.type !== "asictl") {
    vscode.window.showInformationMessage("asictl: no asictl debug session is paused");
    return;
  }
  try {
    await session.customRequest("stepCycle", { threadId: 1 });
  } catch (error) {
    vscode.window.showErrorMessage(`asictl: ${error.message || error}`);
  }
}

/** What each debug session's adapter said: its console and its exit code. */
const transcripts = new Map();

const trackerFactory = {
  createDebugAdapterTracker(session) {
    const transcript = { output: "", exitCode: undefined };
    transcripts.set(session.id, transcript);
    return {
      onDidSendMessage(message) {
        if (message.type !== "event") {
          return;
        }
        if (message.event === "output" && message.body) {
          transcript.output += message.body.output || "";
        } else if (message.event === "exited" && message.body) {
          transcript.exitCode = message.body.exitCode;
        }
      },
    };
  },
};

// ---------------------------------------------------------------- the Testing view

function scenarioItem(controller, uri) {
  const id = uri.toString();
  let item = controller.items.get(id);
  if (!item) {
    item = controller.createTestItem(id, path.basename(uri.fsPath), uri);
    controller.items.add(item);
  }
  return item;
}

function report(run, item, result, durationMs) {
  const messages = result.messages.map((m) => {
    const message = new vscode.TestMessage(m.text);
    const file = m.file ? vscode.Uri.file(path.resolve(path.dirname(item.uri.fsPath), m.file)) : item.uri;
    message.location = new vscode.Location(file, new vscode.Position(Math.max(0, (m.line || 1) - 1), 0));
    return message;
  });
  if (result.status === "passed") {
    run.passed(item, durationMs);
  } else if (result.status === "failed") {
    run.failed(item, messages, durationMs);
  } else {
    run.errored(item, messages, durationMs);
  }
}

function runScenario(item, token) {
  const s = currentSettings();
  const { command, args } = commands.scenarioCommand(s, item.uri.fsPath);
  return new Promise((resolve) => {
    const started = Date.now();
    const child = childProcess.execFile(command, args, { cwd: path.dirname(item.uri.fsPath), maxBuffer: 64 << 20 },
      (error, stdout, stderr) => {
        if (error && error.code === "ENOENT") {
          resolve({ result: { status: "errored", messages: [{ text: startup.notFound("a scenario run", s.command) }] }, ms: 0 });
          return;
        }
        const code = error ? (typeof error.code === "number" ? error.code : 2) : 0;
        resolve({ result: scenarios.outcome(stdout, stderr, code), ms: Date.now() - started });
      });
    token.onCancellationRequested(() => child.kill());
  });
}

/**
 * After a coverage run's scenarios: `asictl test` of them all with an lcov report, in
 * the workspace folder (the report's paths are relative to it), shown through VS Code's
 * test coverage API. A report that cannot be made leaves the run without coverage and
 * says why in its output.
 */
function addCoverage(items, run, token) {
  if (!items.length) {
    return Promise.resolve();
  }
  const s = currentSettings();
  const folder = vscode.workspace.getWorkspaceFolder(items[0].uri);
  const cwd = folder ? folder.uri.fsPath : path.dirname(items[0].uri.fsPath);
  const scratch = fs.mkdtempSync(path.join(os.tmpdir(), "asictl-coverage-"));
  const report = path.join(scratch, "coverage.info");
  const { command, args } = commands.coverageCommand(s, items.map((item) => item.uri.fsPath), report);
  return new Promise((resolve) => {
    const child = childProcess.execFile(command, args, { cwd, maxBuffer: 64 << 20 }, (error, stdout, stderr) => {
      try {
        const text = fs.readFileSync(report, "utf8");
        for (const record of coverage.parseLcov(text)) {
          run.addCoverage(coverage.fileCoverage(vscode, record, (name) => vscode.Uri.file(path.resolve(cwd, name))));
        }
      } catch {
        const why = error && error.code === "ENOENT" ? startup.notFound("a coverage run", s.command) : (stderr || stdout);
        run.appendOutput(`asictl: no coverage report: ${why}`.replace(/\r?\n/g, "\r\n"));
      } finally {
        fs.rmSync(scratch, { recursive: true, force: true });
        resolve();
      }
    });
    token.onCancellationRequested(() => child.kill());
  });
}

async function debugScenario(item, run) {
  const folder = vscode.workspace.getWorkspaceFolder(item.uri);
  const config = { type: "asictl", request: "launch", name: `Debug ${item.label}`, scenario: item.uri.fsPath };
  const started = Date.now();
  let sessionId;
  const ended = new Promise((resolve) => {
    const starting = vscode.debug.onDidStartDebugSession((session) => {
      if (session.configuration.scenario === item.uri.fsPath) {
        sessionId = session.id;
        starting.dispose();
      }
    });
    const done = vscode.debug.onDidTerminateDebugSession((session) => {
      if (session.id === sessionId) {
        done.dispose();
        resolve();
      }
    });
  });
  if (!await vscode.debug.startDebugging(folder, config, { testRun: run })) {
    run.errored(item, [new vscode.TestMessage("the debug session did not start")]);
    return;
  }
  await ended;
  const transcript = transcripts.get(sessionId) || { output: "", exitCode: undefined };
  transcripts.delete(sessionId);
  const messages = scenarios.consoleMessages(transcript.output);
  const status = transcript.exitCode === 0 ? "passed" : transcript.exitCode === undefined ? "errored" : "failed";
  report(run, item, { status, messages: status === "errored" && !messages.length
    ? [{ text: "the debug session ended before the scenario did" }] : messages }, Date.now() - started);
}

function scenarioTests(context) {
  const controller = vscode.tests.createTestController("asictlScenarios", "asictl scenarios");
  context.subscriptions.push(controller);
  const discover = async () => {
    for (const uri of await vscode.workspace.findFiles("**/*.scenario.toml", "**/{node_modules,.git,build,dist}/**")) {
      scenarioItem(controller, uri);
    }
  };
  controller.resolveHandler = async (item) => {
    if (!item) {
      await discover();
    }
  };
  controller.refreshHandler = async () => {
    controller.items.replace([]);
    await discover();
  };
  const watcher = vscode.workspace.createFileSystemWatcher("**/*.scenario.toml");
  watcher.onDidCreate((uri) => scenarioItem(controller, uri));
  watcher.onDidDelete((uri) => controller.items.delete(uri.toString()));
  context.subscriptions.push(watcher);

  const chosen = (request) => {
    const items = [];
    if (request.include) {
      request.include.forEach((item) => items.push(item));
    } else {
      controller.items.forEach((item) => items.push(item));
    }
    return items.filter((item) => !(request.exclude || []).includes(item));
  };
  // A profile runs the chosen scenarios one after the other; `each` runs one, `after`
  // (if any) the ones that ran, together.
  const profile = (label, kind, each, after) => controller.createRunProfile(label, kind, async (request, token) => {
    const run = controller.createTestRun(request);
    const ran = [];
    for (const item of chosen(request)) {
      if (token.isCancellationRequested) {
        run.skipped(item);
        continue;
      }
      run.started(item);
      await each(item, run, token);
      ran.push(item);
    }
    if (after && !token.isCancellationRequested) {
      await after(ran, run, token);
    }
    run.end();
  }, true);
  const runOne = async (item, run, token) => {
    const { result, ms } = await runScenario(item, token);
    report(run, item, result, ms);
  };
  profile("Run", vscode.TestRunProfileKind.Run, runOne);
  profile("Debug", vscode.TestRunProfileKind.Debug, (item, run) => debugScenario(item, run));
  profile("Run with Coverage", vscode.TestRunProfileKind.Coverage, runOne, addCoverage);
}

// ---------------------------------------------------------------- activation

async function activate(context) {
  context.subscriptions.push(
    vscode.debug.registerDebugAdapterDescriptorFactory("asictl", adapterFactory),
    vscode.debug.registerDebugConfigurationProvider("asictl", configurationProvider),
    vscode.debug.registerDebugAdapterTrackerFactory("asictl", trackerFactory),
    vscode.commands.registerCommand("asictl.stepCycle", stepCycle),
    vscode.workspace.onDidChangeConfiguration(async (event) => {
      if (event.affectsConfiguration("asictl")) {
        await stopServer();
        await startServer();
      }
    }),
  );
  scenarioTests(context);
  await startServer();
}

async function deactivate() {
  await stopServer();
}

module.exports = { activate, deactivate };
