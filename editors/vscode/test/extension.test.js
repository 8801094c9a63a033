// The extension against a stand-in for VS Code's API (node's test runner; no editor needed):
// it starts `labsim lsp` over stdio for YAML files, and "labsim: run" / "labsim: view" run
// labsim on the saved file without a shell.
"use strict";

const test = require("node:test");
const assert = require("node:assert");
const Module = require("node:module");
const path = require("node:path");

function standIn() {
  const seen = { clients: [], tasks: [], commands: {}, saved: 0, warnings: [] };
  const document = {
    uri: { fsPath: "/home/student/lab 4/wall; rm -rf ~.yaml" },
    isUntitled: false,
    isDirty: true,
    save: async () => { seen.saved += 1; document.isDirty = false; return true; },
  };
  const vscode = {
    window: {
      activeTextEditor: { document },
      showWarningMessage: (m) => seen.warnings.push(m),
      showErrorMessage: (m) => seen.warnings.push(m),
    },
    workspace: {
      getConfiguration: () => ({ get: (key) => ({ command: "/venv/bin/labsim", runArguments: ["--trace", "run.mcap"] })[key] }),
      getWorkspaceFolder: () => undefined,
      onDidChangeConfiguration: () => ({ dispose() {} }),
    },
    commands: {
      registerCommand: (name, fn) => { seen.commands[name] = fn; return { dispose() {} }; },
      executeCommand: async (name) => seen.commands[name](),
    },
    tasks: { executeTask: async (task) => { seen.tasks.push(task); } },
    ProcessExecution: class { constructor(command, args, options) { Object.assign(this, { command, args, options }); } },
    Task: class { constructor(definition, scope, name, source, execution) { Object.assign(this, { definition, name, source, execution }); } },
    TaskScope: { Workspace: 2 },
    TaskRevealKind: { Always: 1 },
    TaskPanelKind: { Dedicated: 2 },
  };
  const languageclient = {
    TransportKind: { stdio: 0 },
    LanguageClient: class {
      constructor(id, name, server, options) { Object.assign(this, { id, name, server, options }); seen.clients.push(this); }
      start() { this.started = true; return Promise.resolve(); }
      stop() { this.stopped = true; return Promise.resolve(); }
    },
  };
  return { seen, document, modules: { vscode, "vscode-languageclient/node": languageclient } };
}

function load(modules) {
  const original = Module._load;
  Module._load = function (request, ...rest) {
    return request in modules ? modules[request] : original.call(this, request, ...rest);
  };
  try {
    delete require.cache[require.resolve("../extension.js")];
    return require("../extension.js");
  } finally {
    Module._load = original;
  }
}

test("activation starts labsim lsp over stdio for YAML files", () => {
  const { seen, modules } = standIn();
  load(modules).activate({ subscriptions: [] });
  assert.strictEqual(seen.clients.length, 1);
  const [client] = seen.clients;
  assert.deepStrictEqual(client.server, { command: "/venv/bin/labsim", args: ["lsp"], transport: 0 });
  assert.deepStrictEqual(client.options.documentSelector.map((s) => s.language), ["yaml", "yaml"]);
  assert.ok(client.started);
  assert.deepStrictEqual(Object.keys(seen.commands).sort(), ["labsim.restartServer", "labsim.run", "labsim.view"]);
});

test("run and view save the file and run labsim on it without a shell", async () => {
  const { seen, document, modules } = standIn();
  load(modules).activate({ subscriptions: [] });
  await seen.commands["labsim.run"]();
  await seen.commands["labsim.view"]();
  assert.strictEqual(seen.saved, 1);
  const [run, view] = seen.tasks;
  assert.strictEqual(run.execution.command, "/venv/bin/labsim");
  assert.deepStrictEqual(run.execution.args, ["run", document.uri.fsPath, "--trace", "run.mcap"]);
  assert.deepStrictEqual(view.execution.args, ["view", document.uri.fsPath]);
  assert.strictEqual(run.execution.options.cwd, path.dirname(document.uri.fsPath));
});

test("the commands say what to do without a saved file", async () => {
  const { seen, document, modules } = standIn();
  load(modules).activate({ subscriptions: [] });
  document.isUntitled = true;
  await seen.commands["labsim.run"]();
  modules.vscode.window.activeTextEditor = undefined;
  await seen.commands["labsim.view"]();
  assert.deepStrictEqual(seen.warnings, ["labsim run: save the file first", "labsim view: open a behaviour file first"]);
  assert.strictEqual(seen.tasks.length, 0);
});

test("the manifest contributes the commands, the settings and the schemas it ships", () => {
  const manifest = require("../package.json");
  const titles = manifest.contributes.commands.map((c) => `${c.category}: ${c.title}`);
  assert.ok(titles.includes("labsim: run") && titles.includes("labsim: view"));
  assert.deepStrictEqual(manifest.contributes.yamlValidation.map((v) => v.url),
    ["./schemas/behaviour.schema.json", "./schemas/world.schema.json", "./schemas/assignment.schema.json"]);
  assert.ok(manifest.activationEvents.includes("onLanguage:yaml"));
});
