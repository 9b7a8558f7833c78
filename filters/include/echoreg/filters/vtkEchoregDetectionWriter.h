/**
 * @class   vtkEchoregDetectionWriter
 * @brief   Writes the detection table of the A-line pipeline as echoreg's depths CSV.
 *
 * The last step of `echoreg detect`: one row per frame,
 *   frame,timestamp_s,status,reason,peaks,sample_index,depth_mm
 * plus x_mm,y_mm,z_mm when the points are tracked (field data "PointFrame" other than "Beam").
 * Timestamps are written in the shortest form that reads back exactly, sample indices with 3
 * decimals, depths and coordinates with 4; depth and point only for accepted frames, the sample
 * index whenever the single-signal chain chose a peak. docs/formats.md describes the file.
 *
 * The file is written under a temporary name and renamed when complete (echoreg::core::AtomicFile),
 * so a failure leaves no partial output. Errors (no file name, a folder that cannot be written, a
 * table that is not a detection table) are reported with vtkErrorMacro, set the error code and
 * GetLastError(); Write() then returns 0.
 *
 * Input (port 0): vtkTable of vtkEchoregInterSignalFilter.
 * Defaults: no file name.
 */
#pragma once

#include <vtkWriter.h>

#include <string>

class vtkEchoregDetectionWriter : public vtkWriter {
 public:
  static vtkEchoregDetectionWriter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregDetectionWriter, vtkWriter)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * Path of the CSV to write. Default: empty (an error on Write()).
   */
  void SetFileName(const std::string& fileName);
  const std::string& GetFileName() const { return this->FileName; }
  ///@}

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times the file was written.
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregDetectionWriter();
  ~vtkEchoregDetectionWriter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  void WriteData() override;

 private:
  vtkEchoregDetectionWriter(const vtkEchoregDetectionWriter&) = delete;
  void operator=(const vtkEchoregDetectionWriter&) = delete;

  void Fail(const std::string& message);

  std::string FileName;
  std::string LastError;
  int ExecutionCount = 0;
};
