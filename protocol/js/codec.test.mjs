// The JS codec against the shared test vectors (node --test; run by ctest as protocol_js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { checkMessage, decodeFrame, encodeFrameHeader, DEFAULT_LIMITS, ProtocolError } from './codec.js';
import { probeRows } from './planes.js';

const dir = fileURLToPath(new URL('../testdata/', import.meta.url));
const messages = JSON.parse(readFileSync(dir + 'messages.json', 'utf8'));
// clip.set and slice.set have their own file (protocol/js/planes.js)
messages.messages.push(...JSON.parse(readFileSync(dir + 'planes.json', 'utf8')).messages);
const frames = JSON.parse(readFileSync(dir + 'frames.json', 'utf8'));
const probeResults = JSON.parse(readFileSync(dir + 'planes.json', 'utf8')).probe_results;
const limits = { ...DEFAULT_LIMITS, ...messages.limits };

function textOf(vector) {
  if (!vector.length) return vector.text;
  const fill = vector.length - (vector.text.length - '@PAD@'.length);
  return vector.text.replace('@PAD@', 'x'.repeat(fill));
}

for (const vector of messages.messages) {
  test(`message: ${vector.name}`, () => {
    const text = textOf(vector);
    if (vector.length) assert.equal(new TextEncoder().encode(text).length, vector.length);
    if (vector.error) {
      assert.throws(() => checkMessage(text, limits), (e) => {
        assert.ok(e instanceof ProtocolError);
        assert.equal(e.code, vector.error);
        assert.equal(e.id, vector.error_id ?? null);
        assert.ok(e.message.length > 0);
        return true;
      });
    } else {
      assert.deepEqual(checkMessage(text, limits), { type: vector.type, id: vector.id });
    }
  });
}

const hex = (s) => Uint8Array.from(s.match(/../g).map((b) => parseInt(b, 16)));

for (const vector of frames) {
  test(`frame: ${vector.name}`, () => {
    const bytes = hex(vector.hex);
    if (vector.error) {
      assert.throws(() => decodeFrame(bytes.buffer, limits), (e) => e instanceof ProtocolError && e.code === vector.error);
      return;
    }
    const { header, payload } = decodeFrame(bytes.buffer, limits);
    assert.deepEqual(header, vector.header);
    assert.equal(payload.length, vector.header.payload_bytes);
    assert.deepEqual(encodeFrameHeader(header), bytes.subarray(0, 48));
  });
}

for (const vector of probeResults) {
  test(`probe.result: ${vector.name}`, () => {
    assert.deepEqual(probeRows(vector.json), vector.rows);
  });
}
