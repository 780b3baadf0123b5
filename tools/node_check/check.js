'use strict';
// Independent check of the MCAP files dynamap writes and reads, with the Foxglove / MCAP
// project's own JavaScript libraries (installed by scripts/setup.sh; docs/tools.md):
//
//   node check.js FILE_OR_BAG...           each file opens in @mcap/core's stream reader (CRCs
//                                          validated) and indexed reader without an error or a
//                                          warning, and every message decodes against its schema
//                                          (ros2msg + CDR with @foxglove/rosmsg2-serialization,
//                                          JSON against the channel's JSON Schema)
//   node check.js --compare BAG CPP.jsonl  the messages decoded here equal those decoded by the
//                                          C++ reader (dynamap-convert BAG --json)
// Exit status 0 when everything checks, 1 otherwise (the first differences are printed).
const fs = require('fs');
const path = require('path');
const { McapStreamReader, McapIndexedReader } = require('@mcap/core');
const { parse } = require('@foxglove/rosmsg');
const { MessageReader } = require('@foxglove/rosmsg2-serialization');
const fzstd = require('fzstd');

const warnings = [];
console.warn = (...args) => warnings.push(args.join(' '));

const decompressHandlers = {
  zstd: (buffer, size) => fzstd.decompress(buffer, new Uint8Array(Number(size))),
};

function mcapFiles(p) {
  if (!fs.statSync(p).isDirectory()) return [p];
  return fs.readdirSync(p).filter((n) => n.endsWith('.mcap')).sort().map((n) => path.join(p, n));
}

// Every record through the stream reader (CRCs validated); throws on any problem.
function streamRead(file) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(new Uint8Array(fs.readFileSync(file)));
  const out = { schemas: new Map(), channels: new Map(), messages: [], footer: false };
  let rec;
  while ((rec = reader.nextRecord())) {
    if (rec.type === 'Schema') out.schemas.set(rec.id, rec);
    else if (rec.type === 'Channel') out.channels.set(rec.id, rec);
    else if (rec.type === 'Message') out.messages.push(rec);
    else if (rec.type === 'Footer') out.footer = true;
  }
  if (!reader.done()) throw new Error(`${file}: the stream reader is not done (truncated?)`);
  if (!out.footer) throw new Error(`${file}: no footer`);
  return out;
}

async function indexedCount(file) {
  const fd = fs.openSync(file, 'r');
  const size = fs.fstatSync(fd).size;
  const readable = {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const b = Buffer.alloc(Number(length));
      fs.readSync(fd, b, 0, Number(length), Number(offset));
      return new Uint8Array(b.buffer, b.byteOffset, b.length);
    },
  };
  try {
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    let n = 0;
    for await (const m of reader.readMessages()) n += m ? 1 : 0;
    return n;
  } finally {
    fs.closeSync(fd);
  }
}

// A JSON Schema subset (type, properties, items, enum, required): strict, every key described.
function validate(schema, value, where, errors) {
  if (errors.length > 5) return;
  const types = [].concat(schema.type || []);
  const typeOf = (v) => (Array.isArray(v) ? 'array' : v === null ? 'null' : typeof v);
  const t = typeOf(value);
  const ok = types.length === 0 || types.some((s) => s === t || (s === 'integer' && t === 'number' && Number.isInteger(value)));
  if (!ok) errors.push(`${where}: ${t} where the schema says ${types.join('|')}`);
  if (schema.enum && !schema.enum.includes(value)) errors.push(`${where}: ${value} not in the enum`);
  if (t === 'object' && schema.properties) {
    for (const k of Object.keys(value)) {
      if (!(k in schema.properties)) errors.push(`${where}.${k}: not in the schema`);
      else validate(schema.properties[k], value[k], `${where}.${k}`, errors);
    }
    for (const k of schema.required || []) if (!(k in value)) errors.push(`${where}.${k}: missing`);
  }
  if (t === 'array' && schema.items) value.forEach((v, i) => validate(schema.items, v, `${where}[${i}]`, errors));
}

function decoderFor(schema, channel) {
  if (channel.messageEncoding === 'cdr' && schema.encoding === 'ros2msg') {
    const reader = new MessageReader(parse(new TextDecoder().decode(schema.data), { ros2: true }));
    return (data) => reader.readMessage(data);
  }
  if (channel.messageEncoding === 'json' && schema.encoding === 'jsonschema') {
    const js = JSON.parse(new TextDecoder().decode(schema.data));
    return (data, where) => {
      const value = JSON.parse(new TextDecoder().decode(data));
      const errors = [];
      validate(js, value, where, errors);
      if (errors.length) throw new Error(errors.join('\n  '));
      return value;
    };
  }
  throw new Error(`channel ${channel.topic}: encoding ${channel.messageEncoding} / schema ${schema.encoding} unknown here`);
}

// Every message of a file decoded: [{topic, log_time, message}] in file order.
function decodeAll(file) {
  const r = streamRead(file);
  const decoders = new Map();
  return r.messages.map((m) => {
    const ch = r.channels.get(m.channelId);
    if (!ch) throw new Error(`${file}: message on unknown channel ${m.channelId}`);
    if (!decoders.has(ch.id)) decoders.set(ch.id, decoderFor(r.schemas.get(ch.schemaId), ch));
    const where = `${file} topic ${ch.topic} at log time ${m.logTime}`;
    try {
      return { topic: ch.topic, log_time: m.logTime.toString(), message: decoders.get(ch.id)(m.data, where) };
    } catch (e) {
      throw new Error(`${where}: ${e.message}`);
    }
  });
}

function norm(v) {
  if (typeof v === 'bigint') return v.toString();
  if (typeof v === 'number' && !Number.isFinite(v)) return Number.isNaN(v) ? 'NaN' : v > 0 ? 'Infinity' : '-Infinity';
  if (ArrayBuffer.isView(v)) return Array.from(v, norm);
  if (Array.isArray(v)) return v.map(norm);
  if (v && typeof v === 'object') {
    const o = {};
    for (const k of Object.keys(v).sort()) o[k] = norm(v[k]);
    return o;
  }
  return v;
}

async function check(p) {
  let total = 0;
  for (const file of mcapFiles(p)) {
    const messages = decodeAll(file);
    const indexed = await indexedCount(file);
    if (indexed !== messages.length) {
      throw new Error(`${file}: the indexed reader finds ${indexed} messages, the stream reader ${messages.length}`);
    }
    total += messages.length;
  }
  if (warnings.length) throw new Error(`${p}: warnings: ${warnings.join('; ')}`);
  console.log(`node_check: ${p}: ${total} messages decoded (stream + indexed readers, CRCs validated)`);
}

function compare(bag, jsonl) {
  const mine = [];
  for (const file of mcapFiles(bag)) mine.push(...decodeAll(file));
  const byTopic = (a) => [...a].sort((x, y) => (x.topic < y.topic ? -1 : x.topic > y.topic ? 1 : 0));
  const ours = byTopic(mine).map((m) => JSON.stringify(norm(m)));
  const theirs = fs.readFileSync(jsonl, 'utf8').split('\n').filter((l) => l).map((l) => JSON.stringify(norm(JSON.parse(l))));
  let diffs = 0;
  if (ours.length !== theirs.length) {
    console.log(`node_check: ${bag}: ${ours.length} messages here, ${theirs.length} from C++`);
    diffs++;
  }
  for (let i = 0; i < Math.min(ours.length, theirs.length) && diffs < 5; i++) {
    if (ours[i] !== theirs[i]) {
      diffs++;
      console.log(`node_check: ${bag}: message ${i} differs\n  node: ${ours[i].slice(0, 400)}\n  C++:  ${theirs[i].slice(0, 400)}`);
    }
  }
  if (diffs) throw new Error(`${bag}: the C++ reader's values differ from @foxglove/rosmsg2-serialization's`);
  console.log(`node_check: ${bag}: ${ours.length} messages, every value equal to the C++ reader's`);
}

(async () => {
  const args = process.argv.slice(2);
  try {
    if (args[0] === '--compare') compare(args[1], args[2]);
    else for (const p of args) await check(p);
  } catch (e) {
    console.log(`node_check: FAILED: ${e.message}`);
    process.exit(1);
  }
})();
