// Validates a GLB with the Khronos glTF-Validator (npm gltf-validator, pinned
// in package-lock.json and installed by setup.sh; runs offline) and prints
// its report's counts and messages as JSON, for tests/cli/export_command_test.
// Usage: node tests/export/khronos_validate.mjs FILE.glb
import {readFileSync} from 'node:fs';
import validator from 'gltf-validator';

const bytes = readFileSync(process.argv[2]);
try {
  const report = await validator.validateBytes(new Uint8Array(bytes), {maxIssues: 100});
  process.stdout.write(JSON.stringify({
    errors: report.issues.numErrors,
    warnings: report.issues.numWarnings,
    infos: report.issues.numInfos,
    hints: report.issues.numHints,
    messages: report.issues.messages,
    info: report.info,
  }));
} catch (error) {
  process.stdout.write(JSON.stringify({error: String(error)}));
  process.exit(3);
}
