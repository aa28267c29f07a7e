"""Shared fixtures for export tests: the Khronos glTF-Validator (npm), installed on demand."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

IN_CI = os.environ.get("CI", "").lower() in {"1", "true", "yes"}
NODE_DIR = Path(os.environ.get("TERRASCAPE_NODE_CACHE", Path.home() / ".cache/terrascape/node"))

_RUNNER = """
const fs = require('fs');
const validator = require('gltf-validator');
const data = new Uint8Array(fs.readFileSync(process.argv[2]));
validator.validateBytes(data, {maxIssues: 50}).then(
  (report) => { console.log(JSON.stringify(report.issues)); },
  (error) => { console.error(String(error)); process.exit(3); });
"""


#: The system's certificate bundle (Debian/Ubuntu's ca-certificates).
SYSTEM_CA_BUNDLE = Path("/etc/ssl/certs/ca-certificates.crt")


def npm_env() -> dict[str, str]:
    """The environment for npm: Node trusts only its own built-in certificate list, so behind
    a proxy or a company CA that the system trusts (pip and curl work) npm fails with
    SELF_SIGNED_CERT_IN_CHAIN; the system bundle is added unless the user chose one."""
    env = dict(os.environ)
    if "NODE_EXTRA_CA_CERTS" not in env and SYSTEM_CA_BUNDLE.is_file():
        env["NODE_EXTRA_CA_CERTS"] = str(SYSTEM_CA_BUNDLE)
    return env


def _unavailable(reason: str):
    if IN_CI:
        pytest.fail(f"CI must run the glTF validator, but {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="session")
def gltf_validator():
    """``validate(path) -> issues dict`` (numErrors, numWarnings, messages) via node."""
    node = shutil.which("node")
    if node is None:
        _unavailable("node is not installed")
    package = NODE_DIR / "node_modules" / "gltf-validator"
    if not package.exists():
        NODE_DIR.mkdir(parents=True, exist_ok=True)
        npm = shutil.which("npm")
        if npm is None:
            _unavailable("npm is not installed")
        done = subprocess.run([npm, "install", "--no-audit", "--no-fund", "--prefix",
                               str(NODE_DIR), "gltf-validator"], capture_output=True,
                              text=True, timeout=300, env=npm_env())
        if done.returncode != 0 or not package.exists():
            _unavailable(f"npm install gltf-validator failed: {done.stderr[-300:]}")
    runner = NODE_DIR / "validate_glb.js"
    runner.write_text(_RUNNER)

    def validate(path) -> dict:
        done = subprocess.run([node, str(runner), str(path)], capture_output=True, text=True,
                              timeout=120, cwd=NODE_DIR)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    return validate


# An independent glTF reader: glTF-Transform (npm @gltf-transform/core + extensions) with
# meshoptimizer's own JavaScript/WebAssembly decoder for EXT_meshopt_compression.
_READER_PACKAGES = ["@gltf-transform/core@4", "@gltf-transform/extensions@4", "meshoptimizer@0"]
_READER = """
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import { MeshoptDecoder } from 'meshoptimizer';
import fs from 'fs';

await MeshoptDecoder.ready;
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS)
  .registerDependencies({ 'meshopt.decoder': MeshoptDecoder });
const doc = await io.readBinary(new Uint8Array(fs.readFileSync(process.argv[2])));
const root = doc.getRoot();
const out = { extensionsUsed: root.listExtensionsUsed().map((e) => e.extensionName), nodes: [] };
for (const node of root.listNodes()) {
  const entry = { name: node.getName(), world: Array.from(node.getWorldMatrix()), primitives: [] };
  const mesh = node.getMesh();
  if (mesh) {
    for (const prim of mesh.listPrimitives()) {
      const p = { attributes: {}, indices: Array.from(prim.getIndices().getArray()),
                  indexType: prim.getIndices().getComponentType() };
      for (const semantic of prim.listSemantics()) {
        const acc = prim.getAttribute(semantic);
        p.attributes[semantic] = { array: Array.from(acc.getArray()), size: acc.getElementSize(),
                                   componentType: acc.getComponentType(),
                                   normalized: acc.getNormalized() };
      }
      entry.primitives.push(p);
    }
  }
  out.nodes.push(entry);
}
process.stdout.write(JSON.stringify(out));
"""


@pytest.fixture(scope="session")
def gltf_transform_reader():
    """``read(path) -> dict``: nodes (world matrix, primitives with raw attribute arrays and
    indices) as glTF-Transform decodes them, meshopt-compressed buffers included."""
    node = shutil.which("node")
    if node is None:
        _unavailable("node is not installed")
    needed = [NODE_DIR / "node_modules" / p.rsplit("@", 1)[0] for p in _READER_PACKAGES]
    if not all(p.exists() for p in needed):
        NODE_DIR.mkdir(parents=True, exist_ok=True)
        npm = shutil.which("npm")
        if npm is None:
            _unavailable("npm is not installed")
        done = subprocess.run([npm, "install", "--no-audit", "--no-fund", "--prefix",
                               str(NODE_DIR), *_READER_PACKAGES], capture_output=True,
                              text=True, timeout=300, env=npm_env())
        if done.returncode != 0 or not all(p.exists() for p in needed):
            _unavailable(f"npm install of glTF-Transform failed: {done.stderr[-300:]}")
    runner = NODE_DIR / "read_glb.mjs"
    runner.write_text(_READER)

    def read(path) -> dict:
        done = subprocess.run([node, str(runner), str(path)], capture_output=True, text=True,
                              timeout=120, cwd=NODE_DIR)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    return read
