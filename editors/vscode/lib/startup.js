// When asictl cannot start: find the program first, and say what to set when it is not
// there, rather than VS Code's generic "couldn't start the server" / "couldn't create a
// debug adapter". No `vscode` here (unit-tested in Node).
"use strict";

const fs = require("fs");
const path = require("path");

/**
 * The file that `command` names: itself when it contains a path separator, else the
 * first match along PATH (with the PATHEXT endings on Windows). null when there is none.
 */
function findExecutable(command, env = process.env, platform = process.platform, exists = isExecutable) {
  if (!command) {
    return null;
  }
  const endings = platform === "win32" ? ["", ...(env.PATHEXT || ".EXE;.CMD;.BAT").split(";")] : [""];
  const candidates = command.includes("/") || command.includes("\\")
    ? endings.map((ending) => command + ending)
    : (env.PATH || "").split(platform === "win32" ? ";" : ":").filter(Boolean)
      .flatMap((folder) => endings.map((ending) => path.join(folder, command + ending)));
  return candidates.find((candidate) => exists(candidate)) || null;
}

function isExecutable(file) {
  try {
    fs.accessSync(file, fs.constants.X_OK);
    return fs.statSync(file).isFile();
  } catch {
    return false;
  }
}

/** What to tell the user when `what` (the language server, the debug adapter, a
 * scenario run) cannot start with the `asictl.path` setting `command`. */
function notFound(what, command) {
  return `asictl: ${what} cannot start: '${command}' is not a program VS Code can find `
    + "(it searches the PATH it was started with). Set the setting asictl.path to the "
    + "asictl program, e.g. the one in your virtual environment (.venv/bin/asictl), "
    + "and install it with the extras it needs: pip install '.[lsp]' from an asictl checkout.";
}

/** The message for a start that failed after the program was found. */
function failed(what, command, error) {
  const detail = error && error.message ? error.message : String(error);
  return `asictl: ${what} failed to start with asictl.path '${command}': ${detail}. `
    + "Check that setting; the language server also needs the lsp extra (pip install '.[lsp]' from an asictl checkout).";
}

module.exports = { findExecutable, notFound, failed };
