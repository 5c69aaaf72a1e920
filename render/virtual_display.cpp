#include "render/virtual_display.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <mutex>
#include <string>

#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkRenderWindow.h>
#include <vtkWindowToImageFilter.h>

#include <filesystem>

#include "pipeline/error.hpp"

namespace hedgefit::render {

namespace {

bool ExecutableOnPath(const std::string& name, std::string* found) {
  const char* path = std::getenv("PATH");
  std::string p = path ? path : "/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= p.size()) {
    const std::size_t end = p.find(':', start);
    const std::string dir = p.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const std::string candidate = (dir.empty() ? "." : dir) + "/" + name;
    if (access(candidate.c_str(), X_OK) == 0) {
      *found = candidate;
      return true;
    }
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return false;
}

}  // namespace

void EnsureDisplay() {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  const char* display = std::getenv("DISPLAY");
  if (display && *display) return;
  std::string xvfb;
  if (!ExecutableOnPath("Xvfb", &xvfb)) {
    throw Error("rendering needs an X display and none is set (DISPLAY is empty); install a virtual one: "
                "apt-get install xvfb");
  }
  // Xvfb picks a free display number itself and writes it to the pipe (-displayfd).
  int fds[2];
  if (pipe(fds) != 0) throw Error("render: cannot create a pipe to start Xvfb");
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw Error("render: cannot fork to start Xvfb");
  if (pid == 0) {
    // Xvfb ends when hedgefit does, after everything (VTK's static objects included) is
    // done with the display: the kernel sends it SIGTERM when its parent exits. Killing it
    // from an atexit handler instead races those destructors and can abort the process.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(0);
    close(fds[0]);
    const int devnull = open("/dev/null", O_RDWR);
    if (devnull >= 0) {
      dup2(devnull, STDIN_FILENO);
      dup2(devnull, STDOUT_FILENO);
      dup2(devnull, STDERR_FILENO);
    }
    const std::string fd = std::to_string(fds[1]);
    execl(xvfb.c_str(), "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1920x1080x24", "-nolisten", "tcp",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[1]);
  std::string number;
  pollfd p{fds[0], POLLIN, 0};
  for (int waited = 0; waited < 100 && number.find('\n') == std::string::npos; ++waited) {
    if (poll(&p, 1, 100) > 0) {
      char buf[32];
      const ssize_t n = read(fds[0], buf, sizeof(buf));
      if (n <= 0) break;
      number.append(buf, static_cast<std::size_t>(n));
    }
  }
  close(fds[0]);
  while (!number.empty() && (number.back() == '\n' || number.back() == ' ')) number.pop_back();
  if (number.empty()) {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
    throw Error("render: Xvfb (" + xvfb + ") did not start within 10 s; check that it runs: Xvfb :99");
  }
  setenv("DISPLAY", (":" + number).c_str(), 1);
}

void WriteWindowPng(vtkRenderWindow* window, const std::string& png_path) {
  namespace fs = std::filesystem;
  const fs::path target(png_path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + ".png");
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(tmp.string().c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  std::error_code ec;
  if (writer->GetErrorCode() != 0 || !fs::exists(tmp, ec)) {
    fs::remove(tmp, ec);
    throw Error(png_path + ": cannot write the PNG; check free space and permissions");
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(png_path + ": cannot be replaced: " + ec.message());
  }
}

}  // namespace hedgefit::render
