// What e2e.cjs and autopilots.cjs share: the list of failures, frames.csv as rows, a UDP socket
// whose datagrams node-mavlink parses, a run of aerovo, and the script's end (PASS or the
// failures, exit 1). Loaded by require('./harness.cjs'); node-mavlink from NODE_PATH (run_e2e.sh).
'use strict';
const dgram = require('dgram');
const fs = require('fs');
const { spawn } = require('child_process');
const { MavLinkPacketSplitter, MavLinkPacketParser } = require('node-mavlink');

// check(ok, what): records `what` as a failure unless ok; returns ok.
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); return ok; };

// A CSV file with a header line (aerovo's frames.csv) as objects keyed by the header's names;
// the cells stay strings.
function readCsv(file) {
  const lines = fs.readFileSync(file, 'utf8').trim().split('\n');
  const head = lines[0].split(',');
  return lines.slice(1).map(l => {
    const cells = l.split(',');
    const row = {};
    head.forEach((h, i) => { row[h] = cells[i]; });
    return row;
  });
}

// A UDP socket bound to a free port of 127.0.0.1 whose datagrams go through node-mavlink's
// splitter (CRC check: splitter.invalidPackages) and parser; onPacket(packet) for each packet.
async function listen(onPacket) {
  const sock = dgram.createSocket('udp4');
  const splitter = new MavLinkPacketSplitter();
  const parser = splitter.pipe(new MavLinkPacketParser());
  parser.on('data', onPacket);
  sock.on('message', m => splitter.write(m));
  await new Promise(r => sock.bind(0, '127.0.0.1', r));
  return { sock, splitter, port: sock.address().port };
}

// Runs `aerovo args` (its output shown) and resolves to its exit code 300 ms after the exit, so
// that the last datagrams arrive.
async function runAerovo(aerovo, args) {
  const child = spawn(aerovo, args, { stdio: ['ignore', 'inherit', 'inherit'] });
  const code = await new Promise(r => child.on('exit', c => r(c)));
  await new Promise(r => setTimeout(r, 300));
  return code;
}

// Runs the async `main`, then prints PASS (exit 0) or the first `shown` failures (exit 1); an
// exception is a failure.
function finish(main, shown) {
  main().then(() => {
    if (failures.length) {
      console.error(`FAIL (${failures.length}):\n  ` + failures.slice(0, shown).join('\n  '));
      process.exit(1);
    }
    console.log('PASS');
  }, e => { console.error(e); process.exit(1); });
}

module.exports = { failures, check, readCsv, listen, runAerovo, finish };
