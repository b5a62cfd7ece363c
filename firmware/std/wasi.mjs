#!/usr/bin/env -S node --no-warnings
// Runs a wasm32-wasip1 program under Node's WASI (node:wasi, preview 1):
//   ./wasi.mjs PROGRAM.wasm [ARGS...]
// Standard output and error are the process's; exits with the program's
// exit code. Cargo's runner for wasm32-wasip1 (.cargo/config.toml).
import { readFile } from "node:fs/promises";
import { argv, exit } from "node:process";
import { WASI } from "node:wasi";

const [program, ...args] = argv.slice(2);
const wasi = new WASI({ version: "preview1", args: [program, ...args], env: {}, returnOnExit: true });
const module = await WebAssembly.compile(await readFile(program));
const instance = await WebAssembly.instantiate(module, wasi.getImportObject());
exit(wasi.start(instance));
