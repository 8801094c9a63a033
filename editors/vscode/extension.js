// labsim for VS Code: starts `labsim lsp` for YAML files (diagnostics as you type, completion,
// hover, go to definition, rename; docs/editors.md) and contributes "labsim: run" and
// "labsim: view", which run the file in the editor in a terminal of their own. The labsim
// command is the setting labsim.command (default: labsim on the PATH).
"use strict";

const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

function labsimCommand() {
  return vscode.workspace.getConfiguration("labsim").get("command") || "labsim";
}

function startServer(context) {
  const command = labsimCommand();
  const server = { command, args: ["lsp"], transport: TransportKind.stdio };
  client = new LanguageClient("labsim", "labsim", server, {
    // every YAML file: the server answers only for labsim's files (and files that point at
    // its schemas), so a CI workflow open beside a lab gets no labsim errors
    documentSelector: [
      { scheme: "file", language: "yaml" },
      { scheme: "untitled", language: "yaml" },
    ],
  });
  client.start().catch((error) => {
    vscode.window.showErrorMessage(
      `labsim: could not start '${command} lsp' (${error.message || error}). ` +
        "Install labsim (pip install labsim) or set labsim.command to its full path."
    );
  });
  context.subscriptions.push({ dispose: () => client && client.stop() });
}

// Run labsim on the file in the active editor, saved first, in a terminal of its own; the
// arguments go to labsim as they are (no shell), so no file name is ever read as a command.
async function runOnFile(verb, extra) {
  const editor = vscode.window.activeTextEditor;
  if (!editor) {
    vscode.window.showWarningMessage(`labsim ${verb}: open a behaviour file first`);
    return;
  }
  const document = editor.document;
  if (document.isUntitled) {
    vscode.window.showWarningMessage(`labsim ${verb}: save the file first`);
    return;
  }
  if (document.isDirty) {
    await document.save();
  }
  const file = document.uri.fsPath;
  const folder = vscode.workspace.getWorkspaceFolder(document.uri);
  const execution = new vscode.ProcessExecution(labsimCommand(), [verb, file, ...extra], {
    cwd: require("path").dirname(file),
  });
  const task = new vscode.Task({ type: "labsim", verb, file }, folder || vscode.TaskScope.Workspace,
    `${verb} ${require("path").basename(file)}`, "labsim", execution);
  task.presentationOptions = { reveal: vscode.TaskRevealKind.Always, panel: vscode.TaskPanelKind.Dedicated, clear: true };
  await vscode.tasks.executeTask(task);
}

function activate(context) {
  startServer(context);
  const runArguments = () => vscode.workspace.getConfiguration("labsim").get("runArguments") || [];
  context.subscriptions.push(
    vscode.commands.registerCommand("labsim.run", () => runOnFile("run", runArguments())),
    vscode.commands.registerCommand("labsim.view", () => runOnFile("view", [])),
    vscode.commands.registerCommand("labsim.restartServer", async () => {
      if (client) {
        await client.stop();
      }
      startServer(context);
    }),
    vscode.workspace.onDidChangeConfiguration(async (event) => {
      if (event.affectsConfiguration("labsim.command")) {
        await vscode.commands.executeCommand("labsim.restartServer");
      }
    })
  );
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
