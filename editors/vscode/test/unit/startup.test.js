"use strict";
// Finding asictl, and what the user is told when it is not there.
const test = require("node:test");
const assert = require("node:assert/strict");
const fs = require("fs");
const os = require("os");
const path = require("path");

const startup = require("../../lib/startup");

test("a command is found along the PATH, a path is taken as it is", () => {
  const folder = fs.mkdtempSync(path.join(os.tmpdir(), "asictl-path-"));
  const program = path.join(folder, "asictl");
  fs.writeFileSync(program, "#!/bin/sh\n");
  fs.chmodSync(program, 0o755);
  const env = { PATH: ["/nonexistent", folder].join(":") };
  assert.equal(startup.findExecutable("asictl", env, "linux"), program);
  assert.equal(startup.findExecutable(program, {}, "linux"), program);
  assert.equal(startup.findExecutable("asictl", { PATH: "/nonexistent" }, "linux"), null);
  fs.chmodSync(program, 0o644); // not executable: not a program
  assert.equal(startup.findExecutable("asictl", env, "linux"), null);
  assert.equal(startup.findExecutable("", env, "linux"), null);
});

test("on Windows the PATHEXT endings are tried", () => {
  const seen = [];
  const exists = (file) => { seen.push(file); return file.endsWith("asictl.EXE"); };
  const found = startup.findExecutable("asictl", { PATH: "C:\\py\\Scripts", PATHEXT: ".COM;.EXE" }, "win32", exists);
  assert.equal(found, path.join("C:\\py\\Scripts", "asictl.EXE"));
  assert.ok(seen.length >= 2);
});

test("the messages point to the asictl.path setting", () => {
  assert.match(startup.notFound("the debug adapter", "asictl"), /debug adapter cannot start: 'asictl'.*asictl\.path/);
  const message = startup.failed("the language server", "/venv/bin/asictl", new Error("spawn EACCES"));
  assert.match(message, /spawn EACCES.*asictl\.path|asictl\.path '\/venv\/bin\/asictl': spawn EACCES/);
});
