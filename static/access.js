// Who is logged in: the role in the header (#access-role), the log-out button
// (#btn-logout), and the way back to the login page when the login has ended (the
// dashboard restarted, or the login's 12 hours passed). The login itself is an HttpOnly
// cookie: no script here ever sees a token.

const roleBadge = document.getElementById("access-role");

export function toLogin() {
  location.assign("/login");
}

// True (and off to the login page) when `response` says the caller is not logged in.
export function loginEnded(response) {
  if (response.status !== 401) return false;
  toLogin();
  return true;
}

// The caller's role, or null; goes to the login page when the login has ended.
export async function currentRole() {
  let response;
  try {
    response = await fetch("/api/access");
  } catch {
    return null; // the server is away; the feed's status says so
  }
  if (!response.ok) return null;
  const { role } = await response.json();
  if (!role) toLogin();
  return role;
}

async function logout() {
  try {
    await fetch("/logout", { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" });
  } finally {
    toLogin();
  }
}

document.getElementById("btn-logout").addEventListener("click", logout);
currentRole().then((role) => {
  if (!role) return;
  roleBadge.textContent = role;
  roleBadge.title = role === "operator" ? "reads and changes" : "reads only: changes need the operator token";
  document.body.dataset.role = role;
});
