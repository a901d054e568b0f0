// Collect every script error of the page (uncaught errors, rejected promises, console.error) so
// that the self-test can report them; the first script of the page.
(function () {
  'use strict';
  var errors = [];
  window.stokesErrors = errors;
  window.addEventListener('error', function (e) {
    errors.push('error: ' + e.message + ' (' + e.filename + ':' + e.lineno + ')');
  });
  window.addEventListener('unhandledrejection', function (e) {
    var r = e.reason;
    errors.push('unhandled rejection: ' + (r && r.stack ? r.stack : String(r)));
  });
  var consoleError = console.error;
  console.error = function () {
    errors.push('console.error: ' + Array.prototype.map.call(arguments, String).join(' '));
    return consoleError.apply(console, arguments);
  };
})();
