// The AS-i Control IL extension: the TextMate grammar (package.json) colours the code;
// this client starts `asictl lsp`, which gives everything else (diagnostics, hover,
// go to definition, references, completion, outline, folding, formatting).
// Plain JavaScript, so the extension needs no build step.
"use strict";

const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

const clientOptions = {
  documentSelector: [
    { scheme: "file", language: "asi" },
    { scheme: "untitled", language: "asi" },
  ],
};

function serverOptions() {
  const config = vscode.workspace.getConfiguration("asictl");
  const args = ["lsp"];
  for (const folder of config.get("lib", [])) {
    args.push("--lib", folder);
  }
  return { command: config.get("path", "asictl"), args, transport: TransportKind.stdio };
}

async function activate(context) {
  client = new LanguageClient("asictl", "asictl IL language server", serverOptions(),
    clientOptions);
  context.subscriptions.push(
    vscode.workspace.onDidChangeConfiguration(async (event) => {
      if (event.affectsConfiguration("asictl") && client) {
        await client.stop();
        client = new LanguageClient("asictl", "asictl IL language server", serverOptions(),
          clientOptions);
        await client.start();
      }
    }),
  );
  await client.start();
}

async function deactivate() {
  if (client) {
    await client.stop();
  }
}

module.exports = { activate, deactivate };
