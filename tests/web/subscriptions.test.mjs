// node --test tests/web/: the streams panels hold (web/models/subscriptions.js): the server is asked for the
// fastest rate held, and a stream nobody holds any more is withdrawn.
import { test } from "node:test";
import assert from "node:assert/strict";
import { SubscriptionBook, combinedRate } from "../../web/models/subscriptions.js";

test("the rate asked for: every message if anyone wants all, else the fastest", () => {
  assert.equal(combinedRate([5, 10, 2]), 10);
  assert.equal(combinedRate([5, 0, 2]), 0);
  assert.equal(combinedRate([]), undefined);
});

test("a first hold subscribes; a slower second one changes nothing; a faster one raises the rate", () => {
  const book = new SubscriptionBook();
  const a = book.hold("*", "camera/image/compressed", 10);
  assert.deepEqual(a.request, { op: "subscribe", robot: "*", topic: "camera/image/compressed", max_hz: 10 });
  const b = book.hold("*", "camera/image/compressed", 5);
  assert.equal(b.request, null);
  const c = book.hold("*", "camera/image/compressed", 0);
  assert.deepEqual(c.request, { op: "subscribe", robot: "*", topic: "camera/image/compressed", max_hz: 0 });
  assert.notEqual(a.id, b.id);
});

test("releasing lowers the rate to what is still held, and the last release unsubscribes", () => {
  const book = new SubscriptionBook();
  const slow = book.hold("robot1", "imu/data", 5);
  const fast = book.hold("robot1", "imu/data", 50);
  assert.deepEqual(book.release(fast.id), { op: "subscribe", robot: "robot1", topic: "imu/data", max_hz: 5 });
  assert.deepEqual(book.release(slow.id), { op: "unsubscribe", robot: "robot1", topic: "imu/data" });
  assert.equal(book.rate("robot1|imu/data"), undefined);
  assert.equal(book.release(slow.id), null, "a hold released twice changes nothing");
  assert.deepEqual(book.requests(), []);
});

test("a release that leaves the rate as it was sends nothing", () => {
  const book = new SubscriptionBook();
  const first = book.hold("*", "gamestate", 2);
  book.hold("*", "gamestate", 2);
  assert.equal(book.release(first.id), null);
  assert.equal(book.rate("*|gamestate"), 2);
});

test("after a reconnect every held stream is asked for again, once, at its rate", () => {
  const book = new SubscriptionBook();
  book.hold("*", "gamestate", 2);
  book.hold("*", "gamestate", 5);
  book.hold("r1", "a|b", 0); // a topic with the separator in it stays whole
  assert.deepEqual(book.requests(), [
    { op: "subscribe", robot: "*", topic: "gamestate", max_hz: 5 },
    { op: "subscribe", robot: "r1", topic: "a|b", max_hz: 0 },
  ]);
});

test("a bad rate counts as every message, never as a negative rate", () => {
  const book = new SubscriptionBook();
  assert.equal(book.hold("*", "x", -3).request.max_hz, 0);
  assert.equal(book.hold("*", "y", Number.NaN).request.max_hz, 0);
});
