// Scenario files as tests: what `asictl sim --scenario FILE --json` (a run) and the
// debug adapter's console (a debug run) say, turned into a result with messages at the
// scenario's lines. No `vscode` here (unit-tested in Node).
"use strict";

const DIAGNOSTIC = /^(.+?):(\d+):(\d+): (error|warning): (.*)$/;
const FAILURE = /^(.+\.scenario\.toml):(\d+): (at .* expected .*)$/;
const STOP = /^(?:.*: )?(at [\d.]+ ms: program stopped: .*)$/;

/**
 * The result of one scenario run: { status: "passed" | "failed" | "errored",
 * messages: [{ text, file?, line? }] }, lines 1-based as asictl prints them.
 */
function outcome(stdout, stderr, exitCode) {
  let result = null;
  if (exitCode === 0 || exitCode === 1) {
    try {
      result = JSON.parse(stdout);
    } catch {
      result = null;
    }
  }
  if (result === null || typeof result !== "object") {
    return { status: "errored", messages: diagnostics(stderr, stdout, exitCode) };
  }
  const messages = [];
  for (const f of result.failures || []) {
    messages.push({
      text: `at ${f.at_ms} ms: ${f.operand} expected ${f.expected}, got ${f.got}`,
      file: result.scenario, line: f.line,
    });
  }
  for (const s of result.stops || []) {
    const where = s.where ? `${s.where}: ` : "";
    messages.push({ text: `at ${s.at_ms} ms: program stopped: ${where}${s.reason}`, file: result.scenario });
  }
  return { status: result.passed ? "passed" : "failed", messages };
}

function diagnostics(stderr, stdout, exitCode) {
  const messages = [];
  for (const line of (stderr || "").split(/\r?\n/)) {
    const match = DIAGNOSTIC.exec(line);
    if (match && match[4] === "error") {
      messages.push({ text: match[5], file: match[1], line: Number(match[2]) });
    }
  }
  if (!messages.length) {
    const text = (stderr || stdout || "").trim() || `asictl exited with status ${exitCode}`;
    messages.push({ text });
  }
  return messages;
}

/** The failures and program stops a debug session printed in its console. */
function consoleMessages(text) {
  const messages = [];
  for (const line of (text || "").split(/\r?\n/)) {
    let match = FAILURE.exec(line);
    if (match) {
      messages.push({ text: match[3], file: match[1], line: Number(match[2]) });
      continue;
    }
    match = STOP.exec(line);
    if (match) {
      messages.push({ text: match[1] });
    }
  }
  return messages;
}

module.exports = { outcome, consoleMessages };
